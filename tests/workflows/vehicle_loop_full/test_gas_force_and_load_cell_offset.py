"""`nnfmu loop vehicle` on a full-vehicle lab car with a gas force and a load cell offset on one damper."""

from __future__ import annotations

import pytest

from nnfmu.physics import DamperParams
from nnfmu.workflows.roadtest.lab_car import LabCar

pytestmark = pytest.mark.slow  # a full-vehicle lab-car loop (conftest.py)


def test_a_gas_force_and_a_load_cell_offset_on_its_damper_are_both_named(loop) -> None:
    """Both at once on one corner: the LCA angle sees the corner's deflection beside the LVDT, so the gas preload is
    the one cause of the corner's lift and of part of the load cell's shift, and the rest of that shift is the load
    cell's own offset; each named candidate says why it beat its rivals."""
    car = LabCar(damper_effects={"damper_fl": ("gas_force",)}, offsets={"damper_fl_force": 300.0})
    report = loop(car)
    named = [(e.candidate.component, e.candidate.effect) for e in report.attribution.named]
    assert named == [("damper_fl", "gas_force"), ("damper_fl_force", "sensor_offset")]
    gas = report.attribution.named[0]
    assert gas.coefficients[0] == pytest.approx(-DamperParams().gas_preload, rel=0.2)
    assert report.offsets["damper_fl_force"] == pytest.approx(300.0, rel=0.1)
    assert all("the largest drop of BIC" in e.why for e in report.attribution.named)
    angle = report.channels["lca_fl_angle"]
    assert abs(angle["after"].mean_shift) < abs(angle["before"].mean_shift) / 3
