"""A road test's system report: the thesis comparison table, envelope check, run times and links, as `index.html`.

The per-model channel reports (plots, PSDs, damage) are `nnfmu.validate` reports in sub-folders; this page puts the
spline and hysteresis networks side by side against the reference, the way the thesis compared them.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import jinja2

from nnfmu.atomic import write_text_atomic
from nnfmu.workflows.characterise.linked import LinkedCharacterisation

TEMPLATE = "road_test_report.html.j2"


def _number(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.4g}"


def write_system_report(
    summary: Mapping[str, Any],
    context: Mapping[str, str],
    model_reports: Mapping[str, Path],
    path: Path,
    characterisations: Mapping[str, LinkedCharacterisation] | None = None,
) -> Path:
    """Render `summary` (a `SystemResult.to_dict()`) with `context` lines and links to `model_reports` and to each
    network's `characterisations` (or why it has none) into `path`."""
    environment = jinja2.Environment(
        loader=jinja2.FileSystemLoader(Path(__file__).resolve().parent),
        autoescape=True,
        trim_blocks=True,
        lstrip_blocks=True,
        undefined=jinja2.StrictUndefined,
    )
    environment.filters["number"] = _number
    links = {model: os.path.relpath(report, path.parent) for model, report in model_reports.items()}
    characterised = {
        network: {"link": found.link(path), "reason": found.reason}
        for network, found in (characterisations or {}).items()
    }
    html = environment.get_template(TEMPLATE).render(
        summary=summary, context=context, links=links, characterisations=characterised
    )
    write_text_atomic(path, html)
    return path
