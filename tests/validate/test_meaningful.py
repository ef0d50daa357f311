"""Metrics a record is too short for (issue 31): a rainflow damage ratio and an amplitude ratio at 1 Hz on the quick
demo's 0.3 s are "not meaningful (record too short)" in the HTML and null with the reason in the JSON; on a record
long enough they are numbers. Plot titles fit their figure."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from nnfmu.data.measurement import Measurement
from nnfmu.validate import channel_metrics, compare
from nnfmu.validate.meaningful import MIN_DAMAGE_CYCLES, NOT_MEANINGFUL, damage_cycles, damage_reason, frequency_reason
from nnfmu.validate.plots import new_axes
from nnfmu.validate.report import write_report
from nnfmu.workflows.roadtest.budget import budget_rows
from nnfmu.workflows.roadtest.report import write_system_report
from nnfmu.workflows.roadtest.thesis import thesis_row

DT = 1e-3
NAME = "bushing_fl_front_axial_angular_velocity"  # the longest channel name of the full vehicle's report


def road(duration: float) -> np.ndarray:
    """A body mode at 1.3 Hz and a wheel hop at 11 Hz, as a damper force [N]."""
    t = np.arange(0.0, duration, DT)
    return 900.0 * np.sin(2 * np.pi * 1.3 * t) + 300.0 * np.sin(2 * np.pi * 11.0 * t + 0.4)


def measurement(x: np.ndarray) -> Measurement:
    return Measurement(time=np.arange(len(x)) * DT, channels={NAME: x}, units={NAME: "rad/s"}, source="run")


def test_the_rules_need_cycles_and_periods():
    assert damage_cycles(road(0.3)) < MIN_DAMAGE_CYCLES <= damage_cycles(road(10.0))
    assert damage_reason(road(10.0)) is None
    assert damage_reason(road(0.3)).startswith(NOT_MEANINGFUL)
    assert frequency_reason(8.0, np.array([0.0, 0.25]), 1.0) is None
    assert frequency_reason(2.0, np.array([0.0, 0.25]), 1.0).startswith(NOT_MEANINGFUL)  # two periods only
    assert frequency_reason(0.3, np.array([0.0, 3.3]), 1.0).startswith(NOT_MEANINGFUL)


def test_a_short_record_has_no_damage_ratio_a_long_one_has():
    short = channel_metrics(1.1 * road(0.3), road(0.3), 5.0)
    assert math.isnan(short.pseudo_damage_ratio) and short.pseudo_damage_reference > 0  # the damages stay
    as_json = short.to_dict()
    assert as_json["pseudo_damage_ratio"] is None
    assert as_json["not_meaningful"]["pseudo_damage_ratio"].startswith(NOT_MEANINGFUL)
    long = channel_metrics(1.1 * road(10.0), road(10.0), 5.0)
    assert long.pseudo_damage_ratio == pytest.approx(1.1**5, rel=1e-9) and long.not_meaningful == {}


def test_the_validation_report_says_not_meaningful_in_html_and_json(tmp_path):
    x = road(0.3)
    comparisons = compare(measurement(1.1 * x), measurement(x), [NAME])
    index = write_report(comparisons, tmp_path, "short run")
    html = index.read_text(encoding="utf-8")
    assert "not meaningful (record too short)" in html
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    metrics = summary["channels"][0]["metrics"]
    assert (
        metrics["pseudo_damage_ratio"] is None and "rainflow cycles" in metrics["not_meaningful"]["pseudo_damage_ratio"]
    )


def test_the_road_test_tables_say_not_meaningful_for_damage_and_amplitude(tmp_path):
    x = road(0.3)
    (c,) = compare(measurement(1.1 * x), measurement(x), [NAME])
    row = thesis_row(c, "damper-hysteresis").to_dict()
    assert row["damage_ratio"] is None and row["amplitude_ratio_1hz"] is None
    assert set(row["not_meaningful"]) == {"damage_ratio", "amplitude_ratio_1hz"}
    budget = budget_rows("full-vehicle", "damper-hysteresis", [c], [c], {NAME: c})[0].to_dict()
    assert budget["damage_ratio"] is None and budget["not_meaningful"]["damage_ratio"].startswith(NOT_MEANINGFUL)
    summary = {
        "system": "full-vehicle",
        "verdicts": [],
        "thesis_table": [row],
        "budget": [budget],
        "envelope": [],
        "seconds": {},
        "ssds": {},
    }
    html = write_system_report(summary, {}, {}, tmp_path / "index.html").read_text(encoding="utf-8")
    assert html.count("not meaningful (record too short)") == 3  # both thesis columns and the budget's
    (long,) = compare(measurement(1.1 * road(8.0)), measurement(road(8.0)), [NAME])
    row = thesis_row(long, "damper-hysteresis")
    assert row.not_meaningful == {} and row.damage_ratio == pytest.approx(1.1**5, rel=1e-6)
    summary["thesis_table"] = [row.to_dict()]
    summary["budget"] = [budget_rows("full-vehicle", "damper-hysteresis", [long], [long], {NAME: long})[0].to_dict()]
    html = write_system_report(summary, {}, {}, tmp_path / "index.html").read_text(encoding="utf-8")
    assert "not meaningful" not in html and f"{1.1**5:.4g}" in html


@pytest.mark.parametrize(
    "title",
    [
        f"{NAME}: rainflow exceedance; pseudo-damage ratio {NOT_MEANINGFUL} (m = 5)",
        f"{NAME}: rainflow exceedance; pseudo-damage ratio 1.58 (m = 5)",
        "x" * 150,
    ],
)
def test_plot_titles_fit_inside_the_figure(title):
    """The demo's longest rainflow title was clipped at both ends (issue 31): every title line lies inside."""
    figure, axes = new_axes(title)
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    box = axes.title.get_window_extent(canvas.get_renderer())
    assert box.x0 >= 0 and box.x1 <= figure.bbox.width, (box, figure.bbox)
