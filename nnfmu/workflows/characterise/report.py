"""The characterisation report: CSV tables, PNG figures, `summary.json` and `index.html` in one folder.

The HTML shows each section's figures side by side and its tables with the deviation per test point; every table is
also a CSV file beside it. The page is `nnfmu.reports`' (every value escaped).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import nnfmu
from nnfmu.reports.html import write_html
from nnfmu.validate.summary import json_float
from nnfmu.workflows.characterise.tables import Row, write_csv

TEMPLATE = "characterise.html.j2"
SUMMARY_FILE = "summary.json"
INDEX_FILE = "index.html"
MAX_HTML_ROWS = 200  # longer tables (work diagrams, loops) are linked as CSV only


@dataclass
class Section:
    """One part of the report: a title, sentences, figure files and tables (file name -> rows)."""

    title: str
    text: list[str] = field(default_factory=list)
    images: list[str] = field(default_factory=list)
    tables: dict[str, Sequence[Row]] = field(default_factory=dict)


def _json_rows(rows: Sequence[Row]) -> list[dict[str, Any]]:
    return [{k: v if v is None or isinstance(v, str) else json_float(v) for k, v in row.items()} for row in rows]


def _table(name: str, rows: Sequence[Row]) -> dict[str, Any]:
    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    return {"file": name, "columns": list(columns), "rows": _json_rows(rows)}


def write_report(folder: Path, title: str, context: dict[str, str], notes: list[str], sections: list[Section]) -> Path:
    """Write every section's tables as CSV, `summary.json` (tables shown in the HTML included) and `index.html`
    into `folder` (a staging folder: the caller moves it into place)."""
    shown = []
    for s in sections:
        tables = []
        for name, rows in s.tables.items():
            write_csv(folder / name, rows)
            if len(rows) <= MAX_HTML_ROWS:
                tables.append(_table(name, rows))
            else:
                tables.append({"file": name, "columns": [], "rows": []})
        shown.append({"title": s.title, "text": s.text, "images": s.images, "tables": tables})
    summary = {
        "title": title,
        "nnfmu_version": nnfmu.__version__,
        "context": context,
        "notes": notes,
        "sections": shown,
    }
    (folder / SUMMARY_FILE).write_text(json.dumps(summary, indent=1, allow_nan=False), encoding="utf-8")
    write_html(folder / INDEX_FILE, TEMPLATE, summary=summary)
    return folder / INDEX_FILE
