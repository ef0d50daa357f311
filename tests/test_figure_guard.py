"""The suite's figure check finds what a reader would: a title cut at the image's edge, a doubled channel name, tick
labels drawn over each other."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pytest


def _figure(title: str, ylabel: str = "force [N]") -> plt.Figure:
    figure, axes = plt.subplots(figsize=(4, 3), layout="constrained")
    axes.plot([0.0, 1.0], [0.0, 1.0])
    axes.set_title(title)
    axes.set_xlabel("time [s]")
    axes.set_ylabel(ylabel)
    return figure


def test_a_figure_that_fits_saves(tmp_path: Path) -> None:
    figure = _figure("damper force")
    figure.savefig(tmp_path / "fits.png")
    plt.close(figure)


def test_a_title_wider_than_the_image_fails(tmp_path: Path) -> None:
    figure = _figure("rainflow range histogram of the front left damper force " * 3)
    with pytest.raises(AssertionError, match="cut at the image's edge"):
        figure.savefig(tmp_path / "cut.png")
    plt.close(figure)


def test_a_doubled_channel_name_fails(tmp_path: Path) -> None:
    figure = _figure("bushing", ylabel="bushing_axial_force_axial_force [N]")
    with pytest.raises(AssertionError, match="doubles the name 'axial_force'"):
        figure.savefig(tmp_path / "doubled.png")
    plt.close(figure)


def test_a_repeated_word_is_no_doubled_name(tmp_path: Path) -> None:
    figure = _figure("force force, damper_force_rate")
    figure.savefig(tmp_path / "words.png")
    plt.close(figure)


def test_tick_labels_drawn_over_each_other_fail(tmp_path: Path) -> None:
    """A log axis with ticks at a record's measured frequencies, 1.9997 and 2.0003 Hz, both labelled '2'."""
    figure = _figure("dynamic stiffness")
    axes = figure.axes[0]
    axes.set_xscale("log")
    axes.set_xlim(1.0, 20.0)
    axes.set_xticks([1.0, 1.9997, 2.0003, 10.0], ["1", "2", "2", "10"])
    with pytest.raises(AssertionError, match="x tick labels '2' and '2' are drawn over each other"):
        figure.savefig(tmp_path / "ticks.png")
    plt.close(figure)


def test_long_tick_labels_turned_apart_do_not_fail(tmp_path: Path) -> None:
    """Rotated labels whose upright boxes overlap but whose texts do not (a bar chart's channel names at 20 deg)."""
    figure = _figure("damage ratio")
    names = ["damper_force [N]", "body_acceleration [m/s^2]", "damper_displacement [m]"]
    figure.set_size_inches(6.0, 4.5)
    labels = figure.axes[0].set_xticks([0.3, 0.55, 0.8], names, rotation=20, ha="right")
    figure.canvas.draw()
    boxes = [label.get_window_extent() for label in labels]
    assert boxes[0].overlaps(boxes[1]) and boxes[1].overlaps(boxes[2])  # upright, they would collide
    figure.savefig(tmp_path / "turned.png")
    plt.close(figure)
