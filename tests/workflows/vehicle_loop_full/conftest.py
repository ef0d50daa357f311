"""`nnfmu loop vehicle` on full-vehicle lab cars: the virtual car closed by the truth physics as FMUs (damper and
front LCA bushing step graphs, `truth_graphs`), so that its only error before a lab car's hidden change is the
co-simulation's coupling. One lab car per module (each loop is about 100 s), so that xdist's `--dist loadfile`
hands them to different workers; each module builds the car once (the compiles after the first come from the
session's compile cache, `tests/compile_cache.py`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from nnfmu.data.drive_files import read_drive, write_drive
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest.lab_car import LabCar, write_lab_car
from nnfmu.workflows.roadtest.systems import build_truth_fmus, build_vehicle, write_system
from nnfmu.workflows.vehicle_loop import VehicleLoopReport, VehicleLoopSettings, run_vehicle_loop

DURATION = 8.0  # s of lab record


@pytest.fixture(scope="module")
def truth_car(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The full vehicle with the truth physics' damper and bushing step graphs as its component FMUs, and a drive."""
    folder = tmp_path_factory.mktemp("truth-car")
    truth = build_truth_fmus(folder / "fmu", 1e-3, with_bushing=True)
    vehicle = build_vehicle("full-vehicle", folder / "fmu", 1e-3)
    ssd = write_system("full-vehicle", vehicle, truth.dampers["truth"], truth.bushing, folder / "system")
    drive = write_drive(generate_drive(DriveSettings(duration=DURATION + 0.001, seed=5)), folder / "drive.csv")
    return ssd, drive


@pytest.fixture
def loop(truth_car: tuple[Path, Path], tmp_path: Path) -> Callable[[LabCar], VehicleLoopReport]:
    """The vehicle loop on a lab car's record of the drive, written under the test's `tmp_path/out`."""

    def run(car: LabCar) -> VehicleLoopReport:
        ssd, drive = truth_car
        record = write_lab_car(car, read_drive(drive), tmp_path / "lab.csv")
        return run_vehicle_loop(record, ssd, drive, tmp_path / "out", VehicleLoopSettings(), log=lambda _: None)

    return run
