"""The stabilised ports' per-step elements (`port_gains`): inputs that equal the fitted elements, or are not switched
on, leave the vehicle's step graph bit for bit as without them; values below 0 count as 0 (the passive range)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from nnfmu.component import Component
from nnfmu.export.step_runner import run_step_graph
from nnfmu.vehicle.fmu import VehicleBuildSettings
from nnfmu.vehicle.fmu.errors import VehicleBuildError
from nnfmu.vehicle.fmu.settings import MAX_SUBSTEP
from nnfmu.vehicle.fmu.vehicle_fmu import initial_state, port_gain_correction, vehicle_model, vehicle_step_graph

FITTED = (1.0e5, 1500.0)  # N/m, N.s/m: the damper port's element as built
BASE = VehicleBuildSettings(
    components={"damper": "stabilised"}, sample_period=1e-3, stabilisers={"damper_force": FITTED}
)
STIFFNESS, DAMPING = "damper_force_per_damper_displacement", "damper_force_per_damper_velocity"


@pytest.fixture(scope="module")
def graphs():
    """The quarter car's step graph without and with the derivative inputs, and inputs for 200 samples."""
    plain = vehicle_step_graph("quarter-car", BASE)
    with_inputs = vehicle_step_graph("quarter-car", dataclasses.replace(BASE, port_derivatives=True))
    rng = np.random.default_rng(3)
    n = 200
    post = np.cumsum(rng.normal(0.0, 2e-4, n))
    inputs = {
        "actuator_fl_displacement": post,
        "actuator_fl_velocity": np.gradient(post, 1e-3),
        "damper_force": rng.normal(0.0, 300.0, n),
    }
    return plain, with_inputs, inputs


def _run(graph, inputs, stiffness, damping, given):
    n = len(next(iter(inputs.values())))
    extra = {
        STIFFNESS: np.full(n, stiffness),
        DAMPING: np.full(n, damping),
        f"{STIFFNESS}_given": np.full(n, given[0]),
        f"{DAMPING}_given": np.full(n, given[1]),
    }
    return run_step_graph(graph, inputs | extra)


def test_inputs_named_with_units(graphs) -> None:
    _, with_inputs, _ = graphs
    ports = {p.name: p.unit for p in Component.from_onnx(with_inputs).inputs}
    assert ports[STIFFNESS] == "N/m" and ports[DAMPING] == "N.s/m"
    assert ports[f"{STIFFNESS}_given"] == "1" and ports[f"{DAMPING}_given"] == "1"


def test_fitted_values_given_are_bit_identical(graphs) -> None:
    plain, with_inputs, inputs = graphs
    before = run_step_graph(plain, inputs)
    for values, given in ((FITTED, (1.0, 1.0)), ((9e5, 0.0), (0.0, 0.0)), ((FITTED[0], 7e3), (1.0, 0.0))):
        after = _run(with_inputs, inputs, *values, given)
        assert all(np.array_equal(before[k], after[k]) for k in before), (values, given)


def test_other_values_change_the_motion(graphs) -> None:
    plain, with_inputs, inputs = graphs
    before = run_step_graph(plain, inputs)
    after = _run(with_inputs, inputs, 4e5, 3000.0, (1.0, 1.0))
    assert np.max(np.abs(after["damper_displacement"] - before["damper_displacement"])) > 1e-6


def test_negative_values_count_as_zero(graphs) -> None:
    _, with_inputs, inputs = graphs
    zero = _run(with_inputs, inputs, 0.0, 0.0, (1.0, 1.0))
    negative = _run(with_inputs, inputs, -5e6, -1e4, (1.0, 1.0))
    assert all(np.array_equal(zero[k], negative[k]) for k in zero)
    assert all(np.all(np.isfinite(v)) for v in negative.values())


def test_no_stabilised_port_refused() -> None:
    with pytest.raises(VehicleBuildError, match="no force port is stabilised"):
        vehicle_step_graph("quarter-car", VehicleBuildSettings(port_derivatives=True))


def test_graph_follows_the_numpy_correction(graphs) -> None:
    """The graph's arithmetic is `GainCorrection.correct` after the exact step (outputs to 1e-9 of their spread)."""
    _, with_inputs, inputs = graphs
    given = (4e5, 3000.0)
    outputs = _run(with_inputs, inputs, *given, (1.0, 1.0))
    settings = dataclasses.replace(BASE, port_derivatives=True)
    vehicle = vehicle_model("quarter-car", settings)
    discrete = vehicle.discretise(settings.sample_period, "foh", MAX_SUBSTEP)
    correction = port_gain_correction(discrete)
    dk, dc = correction.changes(np.array([given[0]]), np.array([given[1]]))
    u = np.column_stack([inputs[p.name] for p in vehicle.inputs])
    x = np.array(initial_state(vehicle))
    expected = [vehicle.output_vector(x, u[0])]
    for k in range(1, len(u)):
        x = correction.correct(x, discrete.step(x, u[k - 1], u[k]), dk, dc)
        expected.append(vehicle.output_vector(x, u[k]))
    expected = np.array(expected)
    for i, name in enumerate(vehicle.output_names):
        spread = np.ptp(expected[:, i]) or 1.0
        assert np.max(np.abs(outputs[name] - expected[:, i])) <= 1e-9 * spread, name
