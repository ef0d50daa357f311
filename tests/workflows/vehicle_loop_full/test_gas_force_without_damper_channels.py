"""`nnfmu loop vehicle` on a full-vehicle lab car with a gas force on one damper, recorded without damper channels."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nnfmu.physics import DamperParams
from nnfmu.workflows.roadtest.lab_car import LabCar

pytestmark = pytest.mark.slow  # a full-vehicle lab-car loop (conftest.py)


def test_without_damper_channels_a_gas_force_is_named_on_its_damper_and_the_report_says_what_it_cannot_tell(
    loop, tmp_path: Path
) -> None:
    """LCA angles and accelerations only: no load cell, no LVDT. The gas force on damper_fl still stands out as that
    damper's effect (it lifts its corner: both arms' angles and the body move), the preload fitted from the motions;
    what these channels cannot tell it from is said in the report's words, and what the missing channels cost."""
    channels = (
        "lca_fl_angle",
        "lca_fr_angle",
        *(f"spindle_{c}_acceleration" for c in ("fl", "fr", "rl", "rr")),
        *(f"body_acceleration_{c}" for c in ("fl", "fr", "rl", "rr")),
    )
    report = loop(LabCar(damper_effects={"damper_fl": ("gas_force",)}, channels=channels))
    first = report.attribution.named[0]
    assert (first.candidate.component, first.candidate.effect) == ("damper_fl", "gas_force")
    assert first.p_value < 1e-6
    assert not any(e.candidate.component.startswith("bushing") for e in report.attribution.named)
    assert first.coefficients[0] == pytest.approx(-DamperParams().gas_preload, rel=0.2)  # the preload pushes out
    assert first.coefficients[1] == pytest.approx(DamperParams().gas_rate, rel=0.3)
    assert report.fixes[0].element == "damper_fl" and report.fixes[0].method.startswith("physical terms fitted")
    assert not report.in_situ  # nothing to diagnose in situ without load cell and LVDT
    angle = report.channels["lca_fl_angle"]
    assert angle["after"].nrmse < angle["before"].nrmse / 3
    written = json.loads((tmp_path / "out" / "report.json").read_text())
    evidence = written["iterations"][0]["evidence"]
    alike = written["candidates"][0]["cannot_tell_apart_from"]
    assert alike and all(f"{k}" in evidence for k in alike)  # the evidence says what it cannot tell it from
    html = (tmp_path / "out" / "report.html").read_text()
    assert "cannot be told apart from" in html and "cannot tell it apart" in written["summary"]
    coverage = " ".join(written["coverage"])
    assert "no damper force measured" in coverage and "damper_fl_force, damper_fl_displacement not measured" in coverage
    assert "a zero offset of that corner's LCA angle or LVDT also gives" in coverage
    assert "no damper force measured" in html
