"""`nnfmu loop vehicle` on full-vehicle lab cars: the virtual car closed by the truth physics as FMUs (damper and
front LCA bushing step graphs, `truth_graphs`), so that its only error before a lab car's hidden change is the
co-simulation's coupling. An aged (stiffer) LCA bushing is named as its arm's bushing stiffness and fixed by terms."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nnfmu.data.drive_files import read_drive, write_drive
from nnfmu.physics import DamperParams
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest.lab_car import LabCar, write_lab_car
from nnfmu.workflows.roadtest.systems import build_truth_fmus, build_vehicle, write_system
from nnfmu.workflows.vehicle_loop import VehicleLoopReport, VehicleLoopSettings, run_vehicle_loop

pytestmark = pytest.mark.slow  # full-vehicle lab-car loops

DURATION = 8.0  # s of lab record
CORNER_CHANNELS = (  # what a front-left LCA bushing moves first: its arm, its corner's strut, wheel and body
    "lca_fl_angle",
    "damper_fl_displacement",
    "damper_fl_force",
    "spindle_fl_acceleration",
    "body_acceleration_fl",
)


@pytest.fixture(scope="module")
def truth_car(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The full vehicle with the truth physics' damper and bushing step graphs as its component FMUs, and a drive."""
    folder = tmp_path_factory.mktemp("truth-car")
    truth = build_truth_fmus(folder / "fmu", 1e-3, with_bushing=True)
    vehicle = build_vehicle("full-vehicle", folder / "fmu", 1e-3)
    ssd = write_system("full-vehicle", vehicle, truth.dampers["truth"], truth.bushing, folder / "system")
    drive = write_drive(generate_drive(DriveSettings(duration=DURATION + 0.001, seed=5)), folder / "drive.csv")
    return ssd, drive


def loop(car: LabCar, truth_car: tuple[Path, Path], folder: Path) -> VehicleLoopReport:
    ssd, drive = truth_car
    record = write_lab_car(car, read_drive(drive), folder / "lab.csv")
    return run_vehicle_loop(record, ssd, drive, folder / "out", VehicleLoopSettings(), log=lambda _: None)


def test_a_stiffer_lca_bushing_is_named_on_its_arm_and_fixed_by_terms(truth_car, tmp_path: Path) -> None:
    """The two bushings of one arm deflect in mirror image as it swings, so a stiffer front and a stiffer rear
    bushing move the lab channels alike (their records differ by about 0.3 % of what the stiffening moves): the
    loop names one of the arm's two, says it cannot tell it from the other, and the fix on it halves the error of
    every channel at that corner."""
    report = loop(LabCar(bushing_stiffness={"bushing_fl_front": 1.5}), truth_car, tmp_path)
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


def test_without_damper_channels_a_gas_force_is_named_on_its_damper_and_the_report_says_what_it_cannot_tell(
    truth_car, tmp_path: Path
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
    report = loop(LabCar(damper_effects={"damper_fl": ("gas_force",)}, channels=channels), truth_car, tmp_path)
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


def test_a_gas_force_and_a_load_cell_offset_on_its_damper_are_both_named(truth_car, tmp_path: Path) -> None:
    """Both at once on one corner: the LCA angle sees the corner's deflection beside the LVDT, so the gas preload is
    the one cause of the corner's lift and of part of the load cell's shift, and the rest of that shift is the load
    cell's own offset; each named candidate says why it beat its rivals."""
    car = LabCar(damper_effects={"damper_fl": ("gas_force",)}, offsets={"damper_fl_force": 300.0})
    report = loop(car, truth_car, tmp_path)
    named = [(e.candidate.component, e.candidate.effect) for e in report.attribution.named]
    assert named == [("damper_fl", "gas_force"), ("damper_fl_force", "sensor_offset")]
    gas = report.attribution.named[0]
    assert gas.coefficients[0] == pytest.approx(-DamperParams().gas_preload, rel=0.2)
    assert report.offsets["damper_fl_force"] == pytest.approx(300.0, rel=0.1)
    assert all("the largest drop of BIC" in e.why for e in report.attribution.named)
    angle = report.channels["lca_fl_angle"]
    assert abs(angle["after"].mean_shift) < abs(angle["before"].mean_shift) / 3
