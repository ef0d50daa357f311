"""The master's default coupling on the vehicle package's quarter car, whose FMU interpolates its inputs and has
feedthrough at communication points, against the exact coupled solution with the drive linear between the steps.

The reference closes a linear damper inside the vehicle model and is simulated with a first-order hold at the
communication step on the same drive samples, so the differences are the coupling error alone. The default (vehicle
first, linear extrapolation of the damper force, refresh at t_{n+1}) must be second order in h for the motion, the
damper force and the body acceleration, which sees the force of t_{n+1} through the refresh; the basic scheme is
first order. Without the refresh the accelerations see the extrapolated force: still second order, 5-15 times worse.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import onnx
import pytest
from cosim_system_helpers import BASIC, DAMPING, VEHICLE_DRIVE, damper_graph, drive

from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.dynamics import QuarterCarParameters, SimulationSettings, build_quarter_car, simulate
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu, initial_state, vehicle_model

DURATION = 1.0  # [s]
STEPS = (2e-3, 1e-3, 0.5e-3)
DRIVE = drive(DURATION, 0.5e-3, corner="fl")  # the quarter car stands on the fl post
CHANNELS = ("damper_velocity", "damper_force", "body_acceleration", "spindle_acceleration")


@pytest.fixture(scope="module")
def systems(tmp_path_factory: pytest.TempPathFactory) -> dict[float, Path]:
    folder = tmp_path_factory.mktemp("feedthrough")
    onnx_path = folder / "damper.onnx"
    onnx.save(damper_graph(), onnx_path)
    damper = build_fmu(onnx_path, BuildOptions(out=folder / "damper.fmu"))
    ssds = {}
    for h in STEPS:
        vehicle = build_vehicle_fmu("quarter-car", folder / f"car_{h:g}.fmu", VehicleBuildSettings(sample_period=h))
        ssds[h] = write_ssd(
            connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper}, folder),
            folder / f"system_{h:g}.ssd",
        )
    return ssds


def exact(h: float) -> dict[str, np.ndarray]:
    """The linear damper inside the vehicle, first-order hold on the drive samples at t_n = n h."""
    params = QuarterCarParameters.load()
    params = replace(params, damper=replace(params.damper, model="linear", damping=DAMPING))
    vehicle = build_quarter_car(params, {"damper": "reference"})
    stride = round(h / DRIVE.sample_period)
    inputs = {name: DRIVE[name][::stride] for name in VEHICLE_DRIVE}
    x0 = np.array(initial_state(vehicle_model("quarter-car", VehicleBuildSettings())))
    result = simulate(vehicle, inputs, SimulationSettings(dt=h, hold="foh"), x0=x0)
    return result | {"damper_force": DAMPING * result["damper_velocity"]}


def errors(systems: dict[float, Path], **settings: object) -> dict[str, list[float]]:
    """Relative peak error of each channel at every step in STEPS."""
    found: dict[str, list[float]] = {name: [] for name in CHANNELS}
    for h in STEPS:
        with open_system(systems[h]) as system:
            result = cosimulate(system, DRIVE, CosimSettings(step=h, **settings)).measurement
        want = exact(h)
        for name in CHANNELS:
            got = result[name]
            found[name].append(float(np.max(np.abs(got - want[name])) / np.max(np.abs(want[name]))))
    return found


def order(errors: list[float]) -> list[float]:
    return [errors[0] / errors[1], errors[1] / errors[2]]


@pytest.mark.slow
def test_the_default_coupling_is_second_order_for_motions_forces_and_accelerations(systems) -> None:
    default = errors(systems)
    for name, e in default.items():
        assert all(3.0 < r < 6.0 for r in order(e)), f"{name}: errors {e} are not second order"
    basic = errors(systems, **BASIC, refresh=False)
    for name in CHANNELS:
        assert default[name][1] * 20 < basic[name][1], (name, default[name][1], basic[name][1])
        assert all(1.6 < r < 2.4 for r in order(basic[name])), f"basic {name}: {basic[name]} not first order"


def test_the_refresh_gives_the_accelerations_the_force_of_the_step_end(systems) -> None:
    unrefreshed, refreshed = errors(systems, refresh=False), errors(systems)
    for name in ("body_acceleration", "spindle_acceleration"):
        assert refreshed[name][1] * 5 < unrefreshed[name][1], (name, refreshed[name][1], unrefreshed[name][1])


def trapezoidal(h: float) -> np.ndarray:
    """Damper force of the implicit trapezoidal exchange, computed here on the vehicle package's model: over each
    step the vehicle ramps from F_n to F_{n+1} (and the drive between its samples), with F_{n+1} = c v(t_{n+1}) solved
    by fixed-point iteration. What iterating the master's step to convergence must give."""
    car = build_quarter_car(QuarterCarParameters.load())
    discrete = car.discretise(h, "foh")
    stride = round(h / DRIVE.sample_period)
    drive_at = {name: DRIVE[name][::stride] for name in VEHICLE_DRIVE}
    velocity = car.output_index("damper_velocity")

    def inputs(force: float, k: int) -> np.ndarray:
        return car.input_vector({"damper_force": force, **{name: drive_at[name][k] for name in VEHICLE_DRIVE}})

    x = np.array(initial_state(vehicle_model("quarter-car", VehicleBuildSettings())))
    force = DAMPING * car.output_vector(x, inputs(0.0, 0))[velocity]
    forces = [force]
    for k in range(len(drive_at[VEHICLE_DRIVE[0]]) - 1):
        end = force
        for _ in range(60):
            x_next = discrete.step(x, inputs(force, k), inputs(end, k + 1))
            end = DAMPING * car.output_vector(x_next, inputs(end, k + 1))[velocity]
        x, force = x_next, end
        forces.append(force)
    return np.array(forces)


@pytest.mark.slow
@pytest.mark.parametrize("refresh", [True, False])
def test_iterating_the_default_converges_to_the_trapezoidal_exchange(systems, refresh: bool) -> None:
    """The fixed point of a step is the implicit trapezoidal exchange, with and without the refresh (a repeat once
    took the drive's slope from the refreshed buffer, holding the drive over the step)."""
    h = 1e-3
    with open_system(systems[h]) as system:
        result = cosimulate(system, DRIVE, CosimSettings(step=h, iterations=30, tolerance=1e-13, refresh=refresh))
    want = trapezoidal(h)
    assert result.unconverged_steps == 0
    got = result.measurement["damper_force"]
    assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))
