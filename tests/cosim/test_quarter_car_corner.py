"""A quarter car names its actuator inputs after its corner, so the master feeds it that corner's drive channels."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nnfmu.cosim.drive_inputs import DriveInputError
from nnfmu.cosim.master import CosimError, CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.data import Measurement
from nnfmu.vehicle.dynamics import SimulationSettings, simulate
from nnfmu.vehicle.dynamics.parameters import DEFAULTS_DIR
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu, vehicle_model

H = 1e-3  # [s] communication step and the vehicle's sample period
EXAMPLE = DEFAULTS_DIR / "midsize_sedan_quarter_car_fl.toml"


def _post(t: np.ndarray, amplitude: float, hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Displacement [m] and velocity [m/s] of a post moving as a sine."""
    w = 2.0 * math.pi * hz
    return amplitude * np.sin(w * t), amplitude * w * np.cos(w * t)


def _drive(t: np.ndarray, posts: dict[str, tuple[np.ndarray, np.ndarray]]) -> Measurement:
    channels, units = {}, {}
    for corner, (x, v) in posts.items():
        channels |= {f"actuator_{corner}_displacement": x, f"actuator_{corner}_velocity": v}
        units |= {f"actuator_{corner}_displacement": "m", f"actuator_{corner}_velocity": "m/s"}
    return Measurement(time=t, channels=channels, units=units, source="four-post test drive")


@pytest.fixture(scope="module")
def front_right(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, VehicleBuildSettings]:
    """SystemStructure.ssd of a quarter car on the fr post (the example file with its corner changed), damper built
    in, and its build settings."""
    folder = tmp_path_factory.mktemp("corner")
    params = folder / "quarter_fr.toml"
    params.write_text(EXAMPLE.read_text(encoding="utf-8").replace('corner = "fl"', 'corner = "fr"'), encoding="utf-8")
    settings = VehicleBuildSettings(params_path=params, components={"damper": "reference"}, sample_period=H)
    fmu = build_vehicle_fmu("quarter-car", folder / "quarter_fr.fmu", settings)
    return write_ssd(
        connect_by_name("fr quarter car", ("vehicle", fmu), {}, folder), folder / "SystemStructure.ssd"
    ), settings


@pytest.mark.slow
def test_a_quarter_car_reads_its_own_corners_channels(front_right: tuple[Path, VehicleBuildSettings]) -> None:
    ssd, settings = front_right
    t = np.arange(2001) * H
    fl, fr = _post(t, 0.01, 1.2), _post(t, 0.004, 7.0)
    with open_system(ssd) as system:
        result = cosimulate(system, _drive(t, {"fl": fl, "fr": fr}), CosimSettings(step=H)).measurement
        without_fl = cosimulate(system, _drive(t, {"fr": fr}), CosimSettings(step=H)).measurement
        swapped = cosimulate(system, _drive(t, {"fl": fr, "fr": fl}), CosimSettings(step=H)).measurement
        with pytest.raises(
            DriveInputError,
            match=r"'actuator_fr_displacement', 'actuator_fr_velocity'.*"
            r"the drive has: actuator_fl_displacement",
        ):
            cosimulate(system, _drive(t, {"fl": fl}), CosimSettings(step=H))
    for name in result.names:  # the fl channels are not read at all
        np.testing.assert_array_equal(result[name], without_fl[name], err_msg=name)
    vehicle = vehicle_model("quarter-car", settings)
    # the vehicle FMU interpolates its drive inputs over a step: the model's first-order-hold solution
    expected = {
        corner: simulate(
            vehicle,
            {"actuator_fr_displacement": x, "actuator_fr_velocity": v},
            SimulationSettings(dt=H, hold="foh"),
            x0=vehicle.equilibrium(),
        )["body_displacement"]
        for corner, (x, v) in (("fl", fl), ("fr", fr))
    }
    got = result["body_displacement"]
    scale = np.max(np.abs(expected["fr"]))
    assert np.max(np.abs(got - expected["fr"])) < 1e-9 * scale
    assert np.max(np.abs(got - expected["fl"])) > 0.5 * scale  # the fl post would move the body quite differently
    assert np.max(np.abs(swapped["body_displacement"] - expected["fl"])) < 1e-9 * np.max(np.abs(expected["fl"]))


def test_a_step_the_vehicle_cannot_honour_is_refused(front_right: tuple[Path, VehicleBuildSettings]) -> None:
    """The vehicle samples every 1 ms and its outputs follow inputs set at its sample times (feedthrough): 2 ms steps
    are whole multiples and run; 2.5 ms or 0.5 ms steps would put communication points between samples: refused."""
    ssd, _ = front_right
    t = np.arange(2001) * H
    drive = _drive(t, {"fr": _post(t, 0.004, 7.0)})
    with open_system(ssd) as system:
        assert cosimulate(system, drive, CosimSettings(step=2 * H)).measurement.time[-1] == pytest.approx(2.0)
        for step in (2.5 * H, 0.5 * H):
            with pytest.raises(CosimError, match=r"'vehicle' samples every 0.001 s .* whole multiple of 0.001 s"):
                cosimulate(system, drive, CosimSettings(step=step))
