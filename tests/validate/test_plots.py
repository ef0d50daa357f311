"""The channel plots: fixed margins that hold every label, and lines reduced to what the pixels show."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

import nnfmu.validate.plots as plots
from nnfmu.data import Measurement
from nnfmu.validate.compare import ValidationSettings, compare


def test_envelope_keeps_every_peak_and_few_points():
    rng = np.random.default_rng(1)
    x = np.arange(50_000) * 1e-4
    y = rng.normal(size=x.size)
    y[12_345] = 9.0  # a one-sample spike a plain every-n-th decimation would miss
    ex, ey = plots.envelope(x, y, max_points=1600)
    assert len(ey) <= 1600 + 4 and np.all(np.diff(ex) > 0)
    assert ey.max() == 9.0 and ey.min() == y.min() and ex[0] == x[0] and ex[-1] == x[-1]
    # each kept point is a sample, and every run of samples has its own extremes kept
    index = np.searchsorted(x, ex)
    assert np.array_equal(y[index], ey)
    run = -(-2 * len(y) // 1600)
    for start in range(0, len(y), run):
        block = y[start : start + run]
        assert block.max() in ey and block.min() in ey
    short = x[:100], y[:100]
    assert plots.envelope(*short, max_points=1600) == short


def _comparison(name: str, unit: str, scale: float, seconds: float = 20.0):
    rng = np.random.default_rng(2)
    time = np.arange(int(seconds * 1000)) / 1000.0
    reference = scale * np.sin(2 * np.pi * 1.3 * time) * (1 + 0.3 * rng.normal(size=time.size))
    result = 1.05 * reference + 0.01 * scale * rng.normal(size=time.size)
    (c,) = compare(
        Measurement(time, {name: result}, {name: unit}, source="result"),
        Measurement(time, {name: reference}, {name: unit}, source="reference"),
        [name],
        ValidationSettings(),
    )
    return c


@pytest.mark.parametrize(
    ("name", "unit", "scale"),
    [
        ("bushing_fl_front_conical_torque", "N.m", 250_000.0),
        ("lca_fl_angle", "rad", 0.0123),
        ("spindle_fl_acceleration", "m/s^2", 3e-7),
        ("bushing_fl_front_radial_displacement", "m", 0.05),  # a two-line rainflow title,
    ],
)
@pytest.mark.slow
def test_every_label_of_each_channel_plot_lies_inside_its_figure(name, unit, scale, tmp_path, monkeypatch):
    """Fixed margins replace constrained layout: title, tick labels, offsets, axis labels and legend all fit."""
    drawn = []

    def keep(figure, path: Path) -> Path:
        drawn.append(figure)
        return path

    monkeypatch.setattr(plots, "_save", keep)
    c = _comparison(name, unit, scale)
    for plot in (plots.plot_time_window, plots.plot_psd, plots.plot_rainflow):
        plot(c, tmp_path / "x.png")
    for figure in drawn:
        assert figure.get_layout_engine() is None  # the fixed margins, not constrained layout
        canvas = FigureCanvasAgg(figure)
        canvas.draw()
        box = figure.axes[0].get_tightbbox(canvas.get_renderer())
        assert box.x0 >= 0 and box.y0 >= 0, (name, figure.axes[0].get_title(), box)
        assert box.x1 <= figure.bbox.width and box.y1 <= figure.bbox.height, (name, figure.axes[0].get_title(), box)


def test_a_long_window_is_drawn_from_its_envelope(tmp_path, monkeypatch):
    drawn = []
    monkeypatch.setattr(plots, "_save", lambda figure, path: drawn.append(figure) or path)
    c = _comparison("damper_force", "N", 1000.0, seconds=30.0)
    plots.plot_time_window(c, tmp_path / "x.png")
    (figure,) = drawn
    lines = figure.axes[0].get_lines()
    inside = (c.time >= c.window[0]) & (c.time <= c.window[1])
    assert inside.sum() > plots.MAX_LINE_POINTS  # 5 s at 1 kHz
    for line, signal in zip(lines, (c.reference, c.result)):
        y = line.get_ydata()
        assert len(y) <= plots.MAX_LINE_POINTS + 4
        assert y.max() == signal[inside].max() and y.min() == signal[inside].min()
