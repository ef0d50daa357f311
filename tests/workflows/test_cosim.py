"""`nnfmu cosim`'s workflow: a vehicle's actuator ports are bound to the drive by name; results land with units."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "cosim"))  # the hand-made quarter car of the master's tests
from cosim_system_helpers import build, damper_graph, drive, write_system  # noqa: E402

from nnfmu.cosim.master import CosimSettings  # noqa: E402
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd  # noqa: E402
from nnfmu.data import load_measurement  # noqa: E402
from nnfmu.data.drive_files import write_drive  # noqa: E402
from nnfmu.errors import SettingsError  # noqa: E402
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
