"""Write a validation report folder: PNG plots per channel, `summary.json` and an `index.html` linking them.

Everything is first written into a hidden staging folder inside `out_dir`, then moved into place file by file with
`index.html` last, so a failure while plotting leaves an earlier report untouched. Files of other names in `out_dir`
are left alone.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

import nnfmu
from nnfmu.atomic import scratch_dir
from nnfmu.reports.html import render
from nnfmu.stopping import check_stop, interrupts_deferred
from nnfmu.validate.compare import ChannelComparison
from nnfmu.validate.metrics import DEFINITIONS
from nnfmu.validate.plots import plot_channel
from nnfmu.validate.summary import json_float
from nnfmu.validate.verdict import Target, verdict

TEMPLATE = "validate.html.j2"
SUMMARY_FILE = "summary.json"
INDEX_FILE = "index.html"


def file_stem(index: int, channel: str) -> str:
    """A file-system-safe, unique stem for channel number `index`: `03_axial_force`."""
    slug = re.sub(r"[^A-Za-z0-9_-]+", "_", channel).strip("_")[:60] or "channel"
    return f"{index:02d}_{slug}"


def channel_summary(c: ChannelComparison, plots: Mapping[str, str]) -> dict[str, Any]:
    """One channel's entry in `summary.json` (JSON-safe floats)."""
    return {
        "name": c.name,
        "unit": c.unit,
        "quantity": c.quantity,
        "basquin_slope": c.basquin_slope,
        "samples": int(len(c.time)),
        "time_span": [json_float(c.time[0]), json_float(c.time[-1])],
        "window": [json_float(c.window[0]), json_float(c.window[1])],
        "metrics": c.metrics.to_dict(),
        "plots": dict(plots),
    }


def report_verdict(comparisons: Sequence[ChannelComparison], target: Target) -> str:
    """The report's one line: its worst channel's NRMSE against `target`, and how many channels pass."""
    worst = max(comparisons, key=lambda c: c.metrics.nrmse if np.isfinite(c.metrics.nrmse) else -1.0)
    passed = sum(bool(c.metrics.nrmse <= target.nrmse) for c in comparisons)
    which = "worst channel " if len(comparisons) > 1 else ""
    return (
        f"{verdict(f'{which}{worst.name} [{worst.unit}]', worst.metrics.nrmse, target)}; {passed} of "
        f"{len(comparisons)} channel{'s' if len(comparisons) > 1 else ''} within"
    )


def summary_document(
    comparisons: Sequence[ChannelComparison],
    title: str,
    context: Mapping[str, str],
    plots: Sequence[Mapping[str, str]],
    target: Target = Target(),
) -> dict[str, Any]:
    """The whole `summary.json` content: title, verdict against `target`, context, metric definitions and every
    channel."""
    return {
        "title": title,
        "nnfmu_version": nnfmu.__version__,
        "verdict": report_verdict(comparisons, target),
        "target": {"nrmse": target.nrmse, "source": target.source},
        "context": dict(context),
        "definitions": dict(DEFINITIONS),
        "channels": [channel_summary(c, p) for c, p in zip(comparisons, plots)],
    }


def render_html(summary: Mapping[str, Any]) -> str:
    """`index.html` from the summary document (`nnfmu.reports`: every value escaped)."""
    return render(TEMPLATE, (summary["verdict"],), summary=summary)


def write_report(
    comparisons: Sequence[ChannelComparison],
    out_dir: str | os.PathLike[str],
    title: str,
    context: Mapping[str, str] | None = None,
    target: Target = Target(),
) -> Path:
    """Write plots, `summary.json` and `index.html` for `comparisons` into `out_dir`, judged against `target`; returns
    the index.html path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with scratch_dir(".report.", out_dir) as stage:
        plots = []
        for index, c in enumerate(comparisons):
            paths = plot_channel(c, stage, file_stem(index, c.name))
            plots.append({kind: path.name for kind, path in paths.items()})
        summary = summary_document(comparisons, title, context or {}, plots, target)
        (stage / SUMMARY_FILE).write_text(json.dumps(summary, indent=2, allow_nan=False), encoding="utf-8")
        (stage / INDEX_FILE).write_text(render_html(summary), encoding="utf-8")
        check_stop()
        with interrupts_deferred():  # the report is published whole or not at all
            for name in [p for channel in plots for p in channel.values()] + [SUMMARY_FILE, INDEX_FILE]:
                os.replace(stage / name, out_dir / name)
    return out_dir / INDEX_FILE
