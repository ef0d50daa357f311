"""`nnfmu loop vehicle` on a full-vehicle lab car with an aged (stiffer) LCA bushing: named as its arm's bushing
stiffness and fixed by terms."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nnfmu.workflows.roadtest.lab_car import LabCar

pytestmark = pytest.mark.slow  # a full-vehicle lab-car loop (conftest.py)

CORNER_CHANNELS = (  # what a front-left LCA bushing moves first: its arm, its corner's strut, wheel and body
    "lca_fl_angle",
    "damper_fl_displacement",
    "damper_fl_force",
    "spindle_fl_acceleration",
    "body_acceleration_fl",
)


def test_a_stiffer_lca_bushing_is_named_on_its_arm_and_fixed_by_terms(loop, tmp_path: Path) -> None:
    """The two bushings of one arm deflect in mirror image as it swings, so a stiffer front and a stiffer rear
    bushing move the lab channels alike (their records differ by about 0.3 % of what the stiffening moves): the
    loop names one of the arm's two, says it cannot tell it from the other, and the fix on it halves the error of
    every channel at that corner."""
    report = loop(LabCar(bushing_stiffness={"bushing_fl_front": 1.5}))
    (first,) = report.attribution.named
    assert (first.candidate.component, first.candidate.effect) in {
        ("bushing_fl_front", "stiffness"),
        ("bushing_fl_rear", "stiffness"),
    }
    other = "bushing_fl_rear" if first.candidate.component == "bushing_fl_front" else "bushing_fl_front"
    assert f"{other}:stiffness" in first.alike
    assert first.p_value < 1e-6
    assert 0.3 < first.coefficients[0] < 0.7  # the fraction of stiffness added (truth: +50 %)
    written = json.loads((tmp_path / "out" / "report.json").read_text())
    (iteration,) = written["iterations"]
    assert f"cannot be told apart from {other}:stiffness" in iteration["evidence"]
    assert "cannot tell it apart" in written["summary"]
    (fix,) = report.fixes
    assert fix.element == first.candidate.component and "of its own stiffness" in fix.method
    for name in CORNER_CHANNELS:
        pair = report.channels[name]
        assert pair["after"].nrmse <= pair["before"].nrmse / 2, name
    angle = report.channels["lca_fl_angle"]  # the static attitude: the stiffer bushing moves the arm's mean angle
    assert abs(angle["after"].mean_shift) < abs(angle["before"].mean_shift) / 3
    assert written["fmus"][first.candidate.component] != written["fmus"][other]
    assert Path(report.fixed_system).is_file()
