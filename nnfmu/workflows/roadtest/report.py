"""A road test's system report: the thesis comparison table, envelope check, run times and links, as `index.html`.

The per-model channel reports (plots, PSDs, damage) are `nnfmu.validate` reports in sub-folders; this page puts the
spline and hysteresis networks side by side against the reference, the way the thesis compared them.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nnfmu.reports.html import write_html
from nnfmu.workflows.characterise.linked import LinkedCharacterisation

TEMPLATE = "roadtest.html.j2"


def write_system_report(
    summary: Mapping[str, Any],
    context: Mapping[str, str],
    model_reports: Mapping[str, Path],
    path: Path,
    characterisations: Mapping[str, LinkedCharacterisation] | None = None,
) -> Path:
    """Render `summary` (a `SystemResult.to_dict()`) with `context` lines and links to `model_reports` and to each
    network's `characterisations` (or why it has none) into `path`."""
    links = {model: os.path.relpath(report, path.parent) for model, report in model_reports.items()}
    characterised = {
        network: {"link": found.link(path), "reason": found.reason}
        for network, found in (characterisations or {}).items()
    }
    return write_html(
        path,
        TEMPLATE,
        summary["verdicts"],
        summary=summary,
        context=context,
        links=links,
        characterisations=characterised,
    )
