"""Every figure the suite saves is read back as a user would see it: nothing cut at the image's edge, no channel name
doubled (issue 31's `bushing_axial_force_axial_force`), no tick labels drawn over each other. Installed for the whole
suite by `tests/conftest.py`."""

from __future__ import annotations

import re
from collections.abc import Iterator

import matplotlib.figure
import matplotlib.text
import numpy as np

TOLERANCE_PX = 1.0  # anti-aliasing may put a text's last pixel on the edge
DOUBLED = re.compile(r"(?<![A-Za-z0-9])([A-Za-z0-9]+(?:_[A-Za-z0-9]+)+)_\1(?![A-Za-z0-9])")

_original_savefig = matplotlib.figure.Figure.savefig


def _named_texts(figure: matplotlib.figure.Figure) -> Iterator[matplotlib.text.Text]:
    """The texts a reader reads for a figure: its own, every axes' titles, axis labels, legends and annotations."""
    yield from figure.texts
    if figure._suptitle is not None:
        yield figure._suptitle
    for axes in figure.axes:
        yield from (axes.title, axes._left_title, axes._right_title, axes.xaxis.label, axes.yaxis.label)
        yield from axes.texts
        legend = axes.get_legend()
        if legend is not None:
            yield from legend.get_texts()
            yield legend.get_title()


def figure_problems(figure: matplotlib.figure.Figure) -> list[str]:
    """What a reader would find wrong in `figure` as drawn: texts cut at the image's edge, doubled channel names."""
    renderer = figure.canvas.get_renderer()
    width, height = figure.bbox.width, figure.bbox.height
    problems = []
    for text in _named_texts(figure):
        content = text.get_text()
        if not text.get_visible() or not content.strip():
            continue
        extent = text.get_window_extent(renderer)
        if (
            extent.x0 < -TOLERANCE_PX
            or extent.y0 < -TOLERANCE_PX
            or extent.x1 > width + TOLERANCE_PX
            or extent.y1 > height + TOLERANCE_PX
        ):
            problems.append(
                f"text {content!r} is cut at the image's edge (spans x {extent.x0:.0f}..{extent.x1:.0f}, "
                f"y {extent.y0:.0f}..{extent.y1:.0f} px of a {width:.0f} x {height:.0f} px image)"
            )
        doubled = DOUBLED.search(content)
        if doubled is not None:
            problems.append(f"text {content!r} doubles the name {doubled.group(1)!r}")
    problems.extend(_overlapping_ticks(figure, renderer))
    tight = figure.get_tightbbox(renderer)
    dpi = figure.dpi
    if tight is not None and not problems:
        outside = (
            tight.x0 * dpi < -TOLERANCE_PX
            or tight.y0 * dpi < -TOLERANCE_PX
            or tight.x1 * dpi > width + TOLERANCE_PX
            or tight.y1 * dpi > height + TOLERANCE_PX
        )
        if outside:
            problems.append(
                f"tick labels or other artists reach beyond the image: drawn {tight.x0 * dpi:.0f}..{tight.x1 * dpi:.0f}"
                f" x {tight.y0 * dpi:.0f}..{tight.y1 * dpi:.0f} px, image {width:.0f} x {height:.0f} px"
            )
    return problems


def _overlapping_ticks(figure: matplotlib.figure.Figure, renderer: object) -> list[str]:
    """Tick labels of one axis drawn over each other (e.g. a log axis with a tick at 14.99 Hz and one at 15.02 Hz),
    each label taken as the rectangle its text fills, turned by its rotation."""
    problems = []
    for axes in figure.axes:
        for name, axis in (("x", axes.xaxis), ("y", axes.yaxis)):
            labels = [t for t in axis.get_ticklabels(which="both") if t.get_visible() and t.get_text().strip()]
            shapes = [(t.get_text(), *_rectangle(t, renderer, figure.dpi)) for t in labels]
            for i, (text, centre, along, across, length, height) in enumerate(shapes):
                for other, other_centre, _, _, other_length, other_height in shapes[i + 1 :]:
                    gap = other_centre - centre
                    apart_along = abs(gap @ along) - (length + other_length) / 2
                    apart_across = abs(gap @ across) - (height + other_height) / 2
                    if apart_along < -TOLERANCE_PX and apart_across < -TOLERANCE_PX:
                        problems.append(f"{name} tick labels {text!r} and {other!r} are drawn over each other")
    return problems


def _rectangle(text: matplotlib.text.Text, renderer: object, dpi: float) -> tuple:
    """Centre [px], unit vectors along and across the text, and its length and height [px]."""
    box = text.get_window_extent(renderer)
    angle = np.radians(text.get_rotation())
    height = text.get_fontsize() * dpi / 72.0
    cos, sin = abs(np.cos(angle)), abs(np.sin(angle))
    length = (box.width - height * sin) / cos if cos > 0.5 else (box.height - height * cos) / sin
    along = np.array([np.cos(angle), np.sin(angle)])
    return (
        np.array([(box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2]),
        along,
        np.array([-along[1], along[0]]),
        length,
        height,
    )


def checked_savefig(figure: matplotlib.figure.Figure, *args: object, **kwargs: object) -> object:
    """`Figure.savefig`, then AssertionError naming each problem `figure_problems` finds in what was saved."""
    result = _original_savefig(figure, *args, **kwargs)
    if kwargs.get("bbox_inches") != "tight":
        problems = figure_problems(figure)
        if problems:
            title = next((t.get_text() for t in _named_texts(figure) if t.get_text().strip()), "untitled")
            raise AssertionError(f"figure {title!r}: " + "; ".join(problems))
    return result


def install() -> None:
    """Check every figure any test saves from now on."""
    matplotlib.figure.Figure.savefig = checked_savefig
