"""The system FMU's sub-stepping pays off in a plain master (issue 33): a trained damper network on the quarter car.

The quarter car sampling at 0.1 ms with the trained damper-hysteresis network of tests/models/data as its damper,
built into system FMUs with inner steps of 0.1 ms and 1 ms, each stepped at H = 1 ms by a hand-written fmpy loop
that knows nothing of nnfmu (drive set at t_n, no input derivatives, doStep, outputs read). Against the monolithic
quarter car with the truth law (`monolithic_reference`, the road test's), the 0.1 ms inner step must beat the 1 ms
one on the damper force and the body acceleration, and its damper force must lie within 1.5 times the network's own
error (the road test's `nrmse_network`: the network replayed open loop on the reference's own damper motion).
Measured: damper force 2.06 % at 0.1 ms, 2.34 % at 1 ms, the network's own 2.28 %; the full vehicle's check is
bench/container_plain.py (docs/system-fmu.md, Accuracy).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from plain_master import plain_run, port_names  # tests/cosim/conftest.py puts tests/cosim on the path

from nnfmu.cosim.container.build import build_system_fmu
from nnfmu.cosim.drive_inputs import DriveInputs
from nnfmu.cosim.master import CosimSettings
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.data import Measurement
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.validate import compare
from nnfmu.vehicle import DriveSettings, generate_drive
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu
from nnfmu.workflows.roadtest import open_loop_replay
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference, settled_state

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler"),
]

H = 1e-3  # [s] the plain master's step
FINE = 1e-4  # [s] the vehicle's sample period and the fine inner step
DURATION = 2.0  # [s] of ISO 8608 class C road, faded in over 0.5 s
NETWORK = Path(__file__).parents[2] / "models" / "data" / "damper-hysteresis-default.onnx"  # trained, 2 kg taken out
CHANNELS = ("damper_force", "body_acceleration")


def plain_fmpy_loop(fmu: Path, drive: Measurement) -> Measurement:
    """`fmu` stepped at H over DURATION by fmpy's FMU2Slave alone (`plain_run`): the drive at t_n set,
    doStep(t_n, H), CHANNELS read; no input derivatives."""
    inputs = port_names(fmu, "input")
    times = np.arange(round(DURATION / H) + 1) * H
    u = DriveInputs(drive, inputs).table(times)  # as nnfmu cosim binds it (rates derived), before the loop
    table = plain_run(fmu, dict(zip(inputs, u.T)), H, CHANNELS, at_start=True, instance="car")
    units = {"damper_force": "N", "body_acceleration": "m/s^2"}
    return Measurement(times, {c: table[:, i] for i, c in enumerate(CHANNELS)}, units, f"{fmu.name} in fmpy")


def test_a_fine_inner_step_brings_a_plain_master_within_the_networks_own_error(tmp_path: Path) -> None:
    damper = build_fmu(NETWORK, BuildOptions(out=tmp_path / "damper.fmu", platforms=("host",)))
    settings = VehicleBuildSettings(sample_period=FINE, initial_state=settled_state("quarter-car"), platforms=("host",))
    vehicle = build_vehicle_fmu("quarter-car", tmp_path / "car.fmu", settings)
    ssd = write_ssd(
        connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper}, tmp_path), tmp_path / "system.ssd"
    )
    drive = generate_drive(DriveSettings(duration=DURATION + H, fade_in=0.5))
    reference = monolithic_reference("quarter-car", drive, {}, FINE).measurement
    errors = {}
    for inner in (FINE, H):
        with open_system(ssd) as system:
            build_system_fmu(
                system, tmp_path / f"system-{inner:g}.fmu", H, inner, CosimSettings(port_derivatives=False)
            )
        result = plain_fmpy_loop(tmp_path / f"system-{inner:g}.fmu", drive)
        errors[inner] = {c.name: c.metrics.nrmse for c in compare(result, reference, list(CHANNELS))}
    own = compare(open_loop_replay(damper, reference, "damper"), reference, ["damper_force"])[0].metrics.nrmse
    for channel in CHANNELS:
        assert errors[FINE][channel] < errors[H][channel], (channel, errors)
    assert errors[FINE]["damper_force"] <= 1.5 * own, (errors, own)
