"""Monolithic reference: the compiled RK4 kernel against the generic per-law path, on both road-test vehicles."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from nnfmu.data import Measurement
from nnfmu.data.rigs import DamperParams, DamperTruth
from nnfmu.vehicle.dynamics import (
    DamperTruthLaw,
    LinearLaw,
    LinearVehicle,
    MonolithicSettings,
    QuarterCarParameters,
    VehicleModelError,
    VehicleParameters,
    build_full_vehicle,
    build_quarter_car,
    monolithic,
    rest_state,
    simulate_monolithic,
    truth_laws,
)
from nnfmu.vehicle.dynamics.ports import CORNERS
from nnfmu.vehicle.fmu import initial_state
from nnfmu.workflows.roadtest.systems import vehicle_components
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference, settled_state

PERIOD = 1e-3  # s, input and output sample period


@pytest.fixture(scope="module")
def params() -> VehicleParameters:
    return VehicleParameters.load()


@dataclass
class PathCount:
    """How many runs took the generic path."""

    generic: int = 0


@pytest.fixture
def paths(monkeypatch: pytest.MonkeyPatch) -> PathCount:
    """Count the runs of the generic path, so a test can tell which path solved."""
    count = PathCount()
    generic = monolithic._solve_generic

    def counted(*args: object):
        count.generic += 1
        return generic(*args)

    monkeypatch.setattr(monolithic, "_solve_generic", counted)
    return count


def _road(t: np.ndarray, phase: float) -> tuple[np.ndarray, np.ndarray]:
    """Post displacement [m] (a 1.3 Hz swell, 9 Hz and 17 Hz ripples) and its rate [m/s]."""
    parts = ((0.015, 1.3), (0.004, 9.0), (0.002, 17.0))
    x = sum(a * np.sin(2 * math.pi * f * t + phase) for a, f in parts)
    v = sum(a * 2 * math.pi * f * np.cos(2 * math.pi * f * t + phase) for a, f in parts)
    return x, v


def _posts(vehicle: LinearVehicle, duration: float) -> dict[str, np.ndarray]:
    """Displacement and velocity of every actuator post of the vehicle, each post with its own phase."""
    t = np.arange(round(duration / PERIOD) + 1) * PERIOD
    posts = [
        n.removesuffix("displacement")
        for n in vehicle.input_names
        if n.startswith("actuator") and n.endswith("displacement")
    ]
    inputs = {}
    for i, post in enumerate(posts):
        inputs[f"{post}displacement"], inputs[f"{post}velocity"] = _road(t, 0.7 * i)
    return inputs


def _both_paths(
    vehicle: LinearVehicle, laws: dict, inputs: dict, x0: np.ndarray, paths: PathCount
) -> tuple[dict, dict]:
    """The run on the compiled path (checked to be that) and on the generic path."""
    compiled = simulate_monolithic(vehicle, laws, inputs, MonolithicSettings(PERIOD), x0=x0)
    assert paths.generic == 0
    generic = simulate_monolithic(vehicle, laws, inputs, MonolithicSettings(PERIOD, compiled=False), x0=x0)
    assert paths.generic == 1
    return compiled, generic


def _assert_equal_to_peak(compiled: dict, generic: dict, tolerance: float = 1e-9) -> None:
    """Every channel of the two runs agrees to `tolerance` of its peak magnitude."""
    assert compiled.keys() == generic.keys()
    for name, values in generic.items():
        assert np.max(np.abs(compiled[name] - values)) <= tolerance * np.max(np.abs(values)), name


@pytest.mark.parametrize(
    "effects",
    [("hysteresis", "seal_friction"), ("hysteresis", "seal_friction", "temperature"), ("gas_force", "temperature"), ()],
)
@pytest.mark.slow
def test_compiled_quarter_car_equals_the_generic_path(
    params: VehicleParameters, paths: PathCount, effects: tuple[str, ...]
) -> None:
    """The truth damper with its hysteresis state (valve inverse), without it (characteristic), with the temperature
    state and with gas force gives the same run on both paths."""
    car = build_quarter_car(QuarterCarParameters.from_vehicle(params))
    laws = {"damper_force": DamperTruthLaw(DamperTruth(DamperParams(), effects))}
    compiled, generic = _both_paths(car, laws, _posts(car, 0.5), car.equilibrium(), paths)
    _assert_equal_to_peak(compiled, generic)
    assert 500.0 < np.max(np.abs(generic["damper_force"])) < 5000.0  # the damper works hard enough to matter


@pytest.mark.slow
def test_compiled_full_vehicle_equals_the_generic_path(paths: PathCount) -> None:
    """The road test's full-vehicle reference (stabilised LCA bushings; every damper and bushing channel on its truth
    law, Maxwell branches and Jenkins friction elements included) is the same on both paths."""
    t = np.arange(401) * PERIOD
    channels = {f"actuator_{c}_displacement": _road(t, 0.7 * i)[0] for i, c in enumerate(CORNERS)}
    drive = Measurement(t, channels, {name: "m" for name in channels}, "four sine posts")
    components = vehicle_components("full-vehicle")
    compiled = monolithic_reference("full-vehicle", drive, components).measurement
    assert paths.generic == 0
    generic = monolithic_reference("full-vehicle", drive, components, compiled=False).measurement
    assert paths.generic == 1
    _assert_equal_to_peak(compiled.channels, generic.channels)
    assert np.max(np.abs(generic["bushing_fl_front_axial_torque"])) > 0.1  # the bushing laws carry load
    assert np.max(np.abs(generic["damper_rr_force"])) > 500.0


def test_built_in_spline_dampers_and_linear_laws_take_the_compiled_path(
    params: VehicleParameters, paths: PathCount
) -> None:
    """Rear dampers built in as splines, front dampers on linear laws, bushings on truth laws: both paths agree."""
    vehicle = build_full_vehicle(
        params, {"damper_rl": "reference", "damper_rr": "reference"} | vehicle_components("full-vehicle")
    )
    laws = truth_laws([p.name for p in vehicle.inputs if not p.name.startswith("actuator")])
    laws |= {"damper_fl_force": LinearLaw(0.0, 3000.0), "damper_fr_force": LinearLaw(500.0, 2500.0)}
    compiled, generic = _both_paths(vehicle, laws, _posts(vehicle, 0.3), np.array(initial_state(vehicle)), paths)
    _assert_equal_to_peak(compiled, generic)
    assert np.max(np.abs(generic["damper_rl_velocity"])) > 0.05


@dataclass(frozen=True)
class _SoftenedLaw(LinearLaw):
    """A law type the compiled kernel does not know (a subclass may change the physics): this one halves the force."""

    def force(self, state: np.ndarray, x: float, v: float) -> float:
        return 0.5 * super().force(state, x, v)


def test_an_unknown_law_type_falls_back_to_the_generic_path(params: VehicleParameters, paths: PathCount) -> None:
    car = build_quarter_car(QuarterCarParameters.from_vehicle(params))
    inputs, x0 = _posts(car, 0.2), car.equilibrium()
    softened = simulate_monolithic(
        car, {"damper_force": _SoftenedLaw(0.0, 3000.0)}, inputs, MonolithicSettings(PERIOD), x0=x0
    )
    assert paths.generic == 1
    halved = simulate_monolithic(
        car, {"damper_force": LinearLaw(0.0, 1500.0)}, inputs, MonolithicSettings(PERIOD), x0=x0
    )
    assert paths.generic == 1
    _assert_equal_to_peak(halved, softened)


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning", "ignore:overflow:RuntimeWarning")
def test_both_paths_report_divergence_at_the_same_time(params: VehicleParameters) -> None:
    """A damper port closed by a spring far too stiff for the step blows up on both paths, at the same sample."""
    car = build_quarter_car(QuarterCarParameters.from_vehicle(params))
    laws = {"damper_force": LinearLaw(1e12, 0.0)}
    messages = []
    for compiled in (True, False):
        with pytest.raises(VehicleModelError, match="diverged at t = ") as info:
            simulate_monolithic(
                car, laws, _posts(car, 0.2), MonolithicSettings(PERIOD, compiled=compiled), x0=car.equilibrium()
            )
        messages.append(str(info.value))
    assert messages[0] == messages[1]


def test_the_reference_starts_at_rest_on_the_truth_physics() -> None:
    """The linear equilibrium holds the LCA on its reference bushings; the truth physics of the rear bushings is the
    front rig bushing's (twice as stiff), so a run started there moves without any input; from the rest state on the
    laws nothing moves."""
    components = vehicle_components("full-vehicle")
    vehicle = build_full_vehicle(VehicleParameters.load(), components)
    laws = truth_laws([p.name for p in vehicle.inputs if not p.name.startswith("actuator")])
    linear = np.array(initial_state(vehicle))
    rest = rest_state(vehicle, laws, linear)
    np.testing.assert_allclose(rest, settled_state("full-vehicle", components), rtol=0, atol=0)
    assert np.max(np.abs(rest - linear)) > 1e-5  # m / rad: the LCA settles elsewhere on the stiffer rear bushings
    still = {p.name: np.zeros(200) for p in vehicle.inputs if p.name.startswith("actuator")}
    settings = MonolithicSettings(sample_period=PERIOD)
    from_linear = simulate_monolithic(vehicle, laws, still, settings, linear)
    from_rest = simulate_monolithic(vehicle, laws, still, settings, rest)
    velocity = "bushing_fl_front_radial_velocity"
    assert np.max(np.abs(from_linear[velocity])) > 1e-3  # m/s: rings at the LCA mode
    for name in vehicle.output_names:
        if name.startswith("bushing_") or name.startswith("body_"):
            assert np.ptp(from_rest[name]) <= 1e-12 * max(1.0, np.max(np.abs(from_rest[name]))), name


def test_the_quarter_car_rests_on_its_linear_equilibrium() -> None:
    """The damper's truth physics carries no force at rest: its rest state is the linear equilibrium."""
    vehicle = build_quarter_car(QuarterCarParameters.load(), vehicle_components("quarter-car"))
    laws = truth_laws([p.name for p in vehicle.inputs if not p.name.startswith("actuator")])
    linear = np.array(initial_state(vehicle))
    np.testing.assert_allclose(rest_state(vehicle, laws, linear), linear, rtol=0, atol=1e-15)
