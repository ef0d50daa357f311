"""Lab cars: the road-test vehicle on the truth physics with undeclared effects and sensor faults, recorded like a
lab export; checked against the plain monolithic reference they are built from."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nnfmu.data import load_measurement
from nnfmu.physics import DamperParams
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest import RoadTestError, monolithic_reference
from nnfmu.workflows.roadtest.lab_car import LAB_CHANNELS, LabCar, lab_car_laws, lab_car_record, write_lab_car
from nnfmu.workflows.roadtest.systems import vehicle_components


@pytest.fixture(scope="module")
def drive():
    return generate_drive(DriveSettings(duration=3.0, seed=4, fade_in=0.5))


def test_a_clean_noiseless_lab_car_is_the_monolithic_reference(drive) -> None:
    record = lab_car_record(LabCar(system="quarter-car", noise=0.0), drive)
    reference = monolithic_reference("quarter-car", drive, vehicle_components("quarter-car")).measurement
    assert set(record.names) == {"actuator_fl_displacement", *LAB_CHANNELS["quarter-car"]}
    for name in LAB_CHANNELS["quarter-car"]:
        np.testing.assert_array_equal(record[name], reference[name])
        assert record.units[name] == reference.units[name]
    np.testing.assert_array_equal(record["actuator_fl_displacement"], drive["actuator_fl_displacement"])


def test_a_sensor_offset_moves_its_channel_only_and_noise_follows_the_channel_rms(drive) -> None:
    clean = lab_car_record(LabCar(system="quarter-car", noise=0.0), drive)
    offset = lab_car_record(LabCar(system="quarter-car", noise=0.0, offsets={"damper_force": 120.0}), drive)
    noisy = lab_car_record(LabCar(system="quarter-car", noise=0.01, seed=3), drive)
    for name in clean.names:
        shift = 120.0 if name == "damper_force" else 0.0
        np.testing.assert_allclose(offset[name] - clean[name], shift, atol=1e-9)
        added = np.std(noisy[name] - clean[name])
        expected = 0.0 if name.startswith("actuator") else 0.01 * np.std(clean[name])
        assert added == pytest.approx(expected, rel=0.1, abs=1e-12), name


def test_a_gas_force_lifts_its_corner_and_loads_its_load_cell(drive) -> None:
    """Gas on the right dampers: their load cells read about the preload in compression at rest, their strokes
    extend, the left corners barely move."""
    clean = lab_car_record(LabCar(noise=0.0), drive)
    gas = lab_car_record(
        LabCar(noise=0.0, damper_effects={"damper_fr": ("gas_force",), "damper_rr": ("gas_force",)}), drive
    )
    preload = DamperParams().gas_preload
    for corner in ("fr", "rr"):
        shift = np.mean(gas[f"damper_{corner}_force"] - clean[f"damper_{corner}_force"])
        assert shift == pytest.approx(-preload, rel=0.1)
        assert np.mean(gas[f"damper_{corner}_displacement"] - clean[f"damper_{corner}_displacement"]) > 3e-3
    for corner in ("fl", "rl"):
        assert abs(np.mean(gas[f"damper_{corner}_force"] - clean[f"damper_{corner}_force"])) < 0.05 * preload


def test_a_stiffer_bushing_scales_every_stiffness_of_its_truth_only() -> None:
    car = LabCar(bushing_stiffness={"bushing_fl_front": 1.5})
    laws, default = lab_car_laws(car), lab_car_laws(LabCar())
    for port in ("axial_force", "radial_force", "axial_torque", "conical_torque"):
        stiff, plain = laws[f"bushing_fl_front_{port}"].truth.params, default[f"bushing_fl_front_{port}"].truth.params
        assert stiff.stiffness == pytest.approx(1.5 * plain.stiffness)
        assert stiff.cubic_stiffness == pytest.approx(1.5 * plain.cubic_stiffness)
        assert np.allclose(stiff.maxwell_stiffness, 1.5 * np.array(plain.maxwell_stiffness))
        assert stiff.friction_max == pytest.approx(1.5 * plain.friction_max)
        assert stiff.maxwell_time == plain.maxwell_time
        assert laws[f"bushing_fl_rear_{port}"].truth.params == default[f"bushing_fl_rear_{port}"].truth.params


def test_the_record_is_a_lab_export_with_units_and_its_truth_beside_it(drive, tmp_path: Path) -> None:
    car = LabCar(system="quarter-car", offsets={"damper_force": 50.0})
    path = write_lab_car(car, drive, tmp_path / "lab.csv")
    header = path.read_text().splitlines()[0]
    assert "damper_force [N]" in header and "spindle_acceleration [m/s^2]" in header
    loaded = load_measurement(path)
    np.testing.assert_allclose(loaded["damper_force"], lab_car_record(car, drive)["damper_force"], rtol=1e-9)
    assert json.loads(Path(f"{path}.truth.json").read_text())["offsets"] == {"damper_force": 50.0}


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"damper_effects": {"damper_xx": ("gas_force",)}}, "no damper 'damper_xx'"),
        ({"damper_effects": {"damper_fl": ("inertia",)}}, "cannot be switched on"),
        ({"bushing_stiffness": {"bushing_fl_front": -1.0}}, "must be positive"),
        ({"system": "quarter-car", "bushing_stiffness": {"bushing_fl_front": 1.5}}, "no network bushing"),
        ({"offsets": {"body_heave": 1.0}}, "must be recorded"),
        ({"noise": float("nan")}, "noise"),
    ],
)
def test_bad_lab_car_settings_are_refused_by_name(settings: dict, message: str) -> None:
    with pytest.raises(RoadTestError, match=message):
        LabCar(**settings)
