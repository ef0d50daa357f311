"""The suite's figure check finds what a reader would: a title cut at the image's edge, a doubled channel name."""

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
