"""PNG plots of one compared channel: time history around the global peak, PSD overlay, rainflow range exceedance.

Figures are drawn on matplotlib's Agg canvas directly (no pyplot, no screen, no global state). Channel names go into
labels with math parsing off, so a name holding `$` or `\\` is printed as it is.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import LogLocator

from nnfmu.validate.compare import ChannelComparison
from nnfmu.validate.damage import rainflow_cycles
from nnfmu.validate.meaningful import NOT_MEANINGFUL

RESULT_STYLE = {"color": "tab:red", "label": "result", "linewidth": 1.0}
REFERENCE_STYLE = {"color": "black", "label": "reference", "linewidth": 1.0}
FIGURE_WIDTH = 8.0  # [in] at 100 dpi
FIGURE_DPI = 100
# Fixed margins [in] of the channel plots, wide enough for a 7-character tick label ("-250000") and a unit-carrying
# axis label: constrained layout measured every tick label twice, 20-30 % of a plot's CPU time (bench/plots.py).
# The top margin grows by a line height per title line.
MARGINS = {"left": 1.0, "right": 0.2, "bottom": 0.55, "top": 0.15}
TITLE_LINE = 0.22  # [in] a 12 pt title line and its spacing
# A line drawn with more points than this is reduced to its min/max envelope per pixel column (`envelope`): the
# pixels show the same trace, peaks included, at a fraction of the drawing cost.
MAX_LINE_POINTS = 2 * int(FIGURE_WIDTH * FIGURE_DPI)
# Characters of a title line: the default 12 pt title font averages ~7.5 px a character, 800 px hold ~100; 70 leaves
# room for wide letters (a longer title was clipped at both ends, issue 31).
TITLE_CHARS = 70


def fit_title(title: str) -> str:
    """`title` wrapped into lines of at most TITLE_CHARS characters (at spaces, else inside a long word)."""
    return "\n".join(textwrap.wrap(title, TITLE_CHARS, break_long_words=True, break_on_hyphens=False)) or title


def axis_label(name: str, unit: str) -> str:
    """`name [unit]`, with `[1]` for a dimensionless quantity."""
    return f"{name} [{unit or '1'}]"


def psd_unit(unit: str) -> str:
    """Unit of a PSD of a signal in `unit`: `N` -> `N^2/Hz`, `m/s` -> `(m/s)^2/Hz`, `` -> `1/Hz`."""
    if not unit:
        return "1/Hz"
    base = unit if unit.replace("_", "").isalnum() else f"({unit})"
    return f"{base}^2/Hz"


def new_axes(title: str, height: float = 4.0, fixed_margins: bool = False):
    """A figure with one grid-lined axes, drawn off-screen (Agg); `title` is shown literally (no math text), wrapped
    to the figure's width. Laid out by matplotlib's constrained layout, or with `fixed_margins` by `MARGINS` (for
    plots whose labels are known to fit them: the channel plots below)."""
    figure = Figure(figsize=(FIGURE_WIDTH, height), dpi=FIGURE_DPI, layout=None if fixed_margins else "constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    wrapped = fit_title(title)
    axes.set_title(wrapped, parse_math=False)
    axes.grid(True, alpha=0.3)
    if fixed_margins:
        top = MARGINS["top"] + TITLE_LINE * (wrapped.count("\n") + 1)
        figure.subplots_adjust(
            left=MARGINS["left"] / FIGURE_WIDTH,
            right=1.0 - MARGINS["right"] / FIGURE_WIDTH,
            bottom=MARGINS["bottom"] / height,
            top=1.0 - top / height,
        )
    return figure, axes


def envelope(x: np.ndarray, y: np.ndarray, max_points: int = MAX_LINE_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """`(x, y)` with at most `max_points` points (and the two ends): beyond that, each run of samples as wide as
    two drawn points keeps its minimum and its maximum in time order, so the drawn line keeps every peak."""
    n = len(y)
    if n <= max_points:
        return x, y
    run = -(-2 * n // max_points)  # samples per run: ceil(n / (max_points / 2))
    whole = n // run * run
    starts = np.arange(0, whole, run)
    blocks = y[:whole].reshape(-1, run)
    picks = [starts + blocks.argmin(axis=1), starts + blocks.argmax(axis=1), [0, n - 1]]
    if whole < n:
        picks.append(whole + np.array([np.argmin(y[whole:]), np.argmax(y[whole:])]))
    keep = np.unique(np.concatenate(picks))
    return x[keep], y[keep]


def log_scale(axes: Axes, which: str) -> None:
    """The `which` ("x" or "y") axis of `axes` on a log scale, minor ticks at 2 and 5 times each decade only:
    matplotlib's eight per decade were 20-30 % of a PSD or rainflow plot's CPU time (bench/plots.py)."""
    (axes.set_xscale if which == "x" else axes.set_yscale)("log")
    (axes.xaxis if which == "x" else axes.yaxis).set_minor_locator(LogLocator(subs=(2.0, 5.0)))


def _save(figure: Figure, path: Path) -> Path:
    figure.savefig(path, format="png")
    return path


def plot_time_window(c: ChannelComparison, path: Path) -> Path:
    """Result over reference inside the comparison's window (the span around the global peak)."""
    figure, axes = new_axes(f"{c.name}: {c.window[0]:g} to {c.window[1]:g} s", fixed_margins=True)
    inside = (c.time >= c.window[0]) & (c.time <= c.window[1])
    axes.plot(*envelope(c.time[inside], c.reference[inside]), **REFERENCE_STYLE)
    axes.plot(*envelope(c.time[inside], c.result[inside]), **RESULT_STYLE)
    axes.set_xlabel("time [s]")
    axes.set_ylabel(axis_label(c.name, c.unit), parse_math=False)
    axes.legend()
    return _save(figure, path)


def plot_psd(c: ChannelComparison, path: Path) -> Path:
    """Welch PSDs of result and reference, log density axis where any density is positive."""
    figure, axes = new_axes(f"{c.name}: power spectral density", fixed_margins=True)
    axes.plot(c.psd_reference.frequency, c.psd_reference.density, **REFERENCE_STYLE)
    axes.plot(c.psd_result.frequency, c.psd_result.density, **RESULT_STYLE)
    if np.any(c.psd_reference.density > 0) or np.any(c.psd_result.density > 0):
        log_scale(axes, "y")  # a constant channel has an all-zero PSD and keeps a linear axis
    axes.set_xlabel("frequency [Hz]")
    axes.set_ylabel(f"PSD [{psd_unit(c.unit)}]", parse_math=False)
    axes.legend()
    return _save(figure, path)


def _exceedance(signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ranges, counts = rainflow_cycles(signal)
    order = np.argsort(ranges)[::-1]
    return ranges[order], np.cumsum(counts[order])


def plot_rainflow(c: ChannelComparison, path: Path) -> Path:
    """Cumulative rainflow cycle count exceeding each range (log-log), the load spectrum behind the damage ratio."""
    ratio = c.metrics.pseudo_damage_ratio
    figure, axes = new_axes(
        f"{c.name}: rainflow exceedance; pseudo-damage ratio "
        + (f"{ratio:.3g}" if np.isfinite(ratio) else NOT_MEANINGFUL)
        + f" (m = {c.basquin_slope:g})",
        fixed_margins=True,
    )
    any_cycles = False
    for signal, style in ((c.reference, REFERENCE_STYLE), (c.result, RESULT_STYLE)):
        ranges, cumulative = _exceedance(signal)
        axes.step(cumulative, ranges, where="post", **style)
        any_cycles = any_cycles or ranges.size > 0
    if any_cycles:
        log_scale(axes, "x")  # a constant channel has no cycles and keeps a linear axis
    axes.set_xlabel("cycles exceeding range [1]")
    axes.set_ylabel(axis_label(f"{c.name} range", c.unit), parse_math=False)
    axes.legend()
    return _save(figure, path)


def plot_channel(c: ChannelComparison, out_dir: Path, stem: str) -> dict[str, Path]:
    """All plots of one channel as `<stem>_time.png`, `<stem>_psd.png`, `<stem>_rainflow.png` in `out_dir`."""
    return {
        "time": plot_time_window(c, out_dir / f"{stem}_time.png"),
        "psd": plot_psd(c, out_dir / f"{stem}_psd.png"),
        "rainflow": plot_rainflow(c, out_dir / f"{stem}_rainflow.png"),
    }
