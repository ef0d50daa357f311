"""The one writer of nnfmu's HTML reports: each report is a template in `templates/reports/` extending `base.html.j2`
(page, style, verdict lines, figures), rendered by one jinja2 environment that escapes every value and refuses an
undefined name, and written atomically."""

from __future__ import annotations

import base64
import functools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jinja2

from nnfmu.atomic import write_text_atomic
from nnfmu.reports.formats import number, p_value_text, per_cent
from nnfmu.resources import templates_dir


@functools.cache
def environment() -> jinja2.Environment:
    """The environment every report renders in (built once: its templates are compiled once per process)."""
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(templates_dir() / "reports"),
        autoescape=True,
        trim_blocks=True,
        lstrip_blocks=True,
        undefined=jinja2.StrictUndefined,
    )
    env.filters.update(number=number, per_cent=per_cent, p_value=p_value_text)
    return env


def render(template: str, verdicts: Sequence[str] = (), **context: Any) -> str:
    """The page of `template` (in `templates/reports/`) for `context`, opening with the `verdicts` lines in bold."""
    return environment().get_template(template).render(verdicts=list(verdicts), **context)


def write_html(path: Path, template: str, verdicts: Sequence[str] = (), **context: Any) -> Path:
    """Render `template` and write it to `path` whole or not at all; returns `path`."""
    write_text_atomic(path, render(template, verdicts, **context))
    return path


def inline_png(png: bytes) -> str:
    """A PNG as a `data:` address, for a figure inside a self-contained page."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")
