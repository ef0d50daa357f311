"""`nnfmu cosim`'s workflow: a vehicle's actuator ports are bound to the drive by name; results land with units."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import onnx
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "cosim"))  # the hand-made quarter car of the master's tests
from cosim_system_helpers import DAMPING, build, damper_graph, drive, write_system  # noqa: E402

from nnfmu.component import Component  # noqa: E402
from nnfmu.cosim.master import CosimSettings, CosimWarning  # noqa: E402
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd  # noqa: E402
from nnfmu.data import load_measurement  # noqa: E402
from nnfmu.data.band import power_above  # noqa: E402
from nnfmu.data.drive_files import write_drive  # noqa: E402
from nnfmu.errors import SettingsError  # noqa: E402
from nnfmu.export.linear_damper import linear_damper_graph  # noqa: E402
from nnfmu.vehicle.dynamics.parameters import DEFAULTS_DIR  # noqa: E402
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu  # noqa: E402
from nnfmu.workflows.cosim import run_cosim  # noqa: E402
from nnfmu.workflows.vehicle_binding import vehicle_binding  # noqa: E402

DRIVE = drive(2.0, 0.5e-3)


@pytest.fixture(scope="module")
def system(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = tmp_path_factory.mktemp("workflow_cosim")
    return write_system(base / "system", 1e-3, build(damper_graph(), base / "components", "damper"))


def test_run_cosim_writes_csv_and_mdf_with_units(system: Path, tmp_path: Path) -> None:
    drive_file = write_drive(DRIVE, tmp_path / "drive.csv")
    for suffix in (".csv", ".mf4"):
        out = tmp_path / f"result{suffix}"
        result = run_cosim(system, drive_file, CosimSettings(step=1e-3, stop_time=0.5), out)
        back = load_measurement(out)
        assert back.units["damper_velocity"] == "m/s" and back.units["damper_force"] == "N"
        np.testing.assert_array_equal(back["body_displacement"], result.measurement["body_displacement"])
        assert back.time[-1] == pytest.approx(0.5, abs=1e-12)
    with pytest.raises(SettingsError, match="unknown master 'simulink'"):
        run_cosim(system, drive_file, CosimSettings(step=1e-3), master="simulink")


@pytest.mark.slow
def test_a_vehicle_binds_only_its_actuator_ports(tmp_path: Path) -> None:
    params = DEFAULTS_DIR / "midsize_sedan_quarter_car_fl.toml"
    settings = VehicleBuildSettings(params_path=params, components={"damper": "reference"}, sample_period=1e-3)
    fmu = build_vehicle_fmu("quarter-car", tmp_path / "quarter_fl.fmu", settings)
    ssd = write_ssd(connect_by_name("fl quarter car", ("vehicle", fmu), {}, tmp_path), tmp_path / "SystemStructure.ssd")
    with open_system(ssd) as structure:
        binding = vehicle_binding(structure)
    assert binding.element == "vehicle"
    assert binding.inputs == binding.channels == ("actuator_fl_displacement", "actuator_fl_velocity")


def test_a_system_without_a_vehicle_falls_back_on_the_masters_default(system: Path) -> None:
    with open_system(system) as structure:
        binding = vehicle_binding(structure)
    assert binding.element == "vehicle" and set(binding.inputs) == set(DRIVE.names)


def test_a_network_driven_past_its_training_envelope_is_named_with_its_range(tmp_path: Path) -> None:
    drive_file = write_drive(DRIVE, tmp_path / "drive.csv")
    inside = write_system(tmp_path / "inside", 1e-3, build(linear_damper_graph(DAMPING), tmp_path / "c1", "damper"))
    narrow = linear_damper_graph(DAMPING, velocity_range=(-0.05, 0.05))  # the drive's damper motion goes further
    outside = write_system(tmp_path / "outside", 1e-3, build(narrow, tmp_path / "c2", "damper"))
    settings = CosimSettings(step=1e-3, stop_time=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", CosimWarning)
        plain = run_cosim(inside, drive_file, settings)  # no envelope known: nothing to say
    with pytest.warns(CosimWarning) as caught:
        result = run_cosim(outside, drive_file, settings)
    said = [str(w.message) for w in caught if "training envelope" in str(w.message)]
    velocity = result.measurement["damper_velocity"]
    assert len(said) == 1, said
    assert f"element 'damper': input 'velocity' reached {velocity.min():.4g} to {velocity.max():.4g} m/s" in said[0]
    assert "[-0.05, 0.05] m/s" in said[0] and f"{np.mean(np.abs(velocity) > 0.05):.2%} of the run" in said[0]
    np.testing.assert_array_equal(result.measurement["damper_force"], plain.measurement["damper_force"])


def _banded(edge: object) -> onnx.ModelProto:
    """The linear damper's graph carrying `edge` as its velocity's training band [Hz]."""
    graph = linear_damper_graph(DAMPING)
    component = Component.from_onnx(graph)
    component.metadata = {"training_band": {"power_share": 0.99, "upper_edge_Hz": {"velocity": edge}}}
    component.attach_to(graph)
    return graph


def test_a_network_driven_above_its_training_band_is_named_with_its_share_of_power(tmp_path: Path) -> None:
    drive_file = write_drive(DRIVE, tmp_path / "drive.csv")
    settings = CosimSettings(step=1e-3, stop_time=1.0)
    wide = write_system(tmp_path / "wide", 1e-3, build(_banded(400.0), tmp_path / "c1", "damper"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", CosimWarning)
        run_cosim(wide, drive_file, settings)  # the run's damper motion lies within 400 Hz
    narrow = write_system(tmp_path / "narrow", 1e-3, build(_banded(1.0), tmp_path / "c2", "damper"))
    with pytest.warns(CosimWarning) as caught:
        result = run_cosim(narrow, drive_file, settings)
    said = [str(w.message) for w in caught if "band" in str(w.message)]
    share = power_above(result.measurement["damper_velocity"], 1e-3, 1.0)
    assert share > 0.05 and len(said) == 1, said
    assert said[0].startswith(f"element 'damper': input 'velocity' held {share:.1%} of its power above 1 Hz, the band")
    broken = write_system(tmp_path / "broken", 1e-3, build(_banded("40"), tmp_path / "c3", "damper"))
    with pytest.warns(CosimWarning, match="training band of input 'velocity' is '40'.*frequencies were not checked"):
        run_cosim(broken, drive_file, settings)
