"""Full vehicle on a four-poster: statics, symmetry, pitch from a delayed input, LCA kinematics, port wiring."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import cont2discrete

from nnfmu.vehicle.dynamics import (
    LinearVehicle,
    MonolithicSettings,
    SimulationSettings,
    VehicleModelError,
    VehicleParameters,
    build_full_vehicle,
    linear_laws,
    simulate,
    simulate_monolithic,
    truth_laws,
)
from nnfmu.vehicle.dynamics.full_vehicle import COMPONENTS
from nnfmu.vehicle.dynamics.ports import component_channels

CORNERS = ("fl", "fr", "rl", "rr")
SI_UNITS = {"m", "m/s", "m/s^2", "N", "N.m", "rad", "rad/s", "rad/s^2"}
ALL_REFERENCE = {name: "reference" for name in COMPONENTS}


@pytest.fixture(scope="module")
def params() -> VehicleParameters:
    return VehicleParameters.load()


@pytest.fixture(scope="module")
def linear_params(params: VehicleParameters) -> VehicleParameters:
    """Default car with the linear reference dampers (the whole model is then linear and exact)."""
    return replace(
        params,
        front_damper=replace(params.front_damper, model="linear"),
        rear_damper=replace(params.rear_damper, model="linear"),
    )


@pytest.fixture(scope="module")
def car(linear_params: VehicleParameters) -> LinearVehicle:
    return build_full_vehicle(linear_params, ALL_REFERENCE)


def _bump(t: np.ndarray, start: float, height: float = 0.02, length: float = 0.1) -> np.ndarray:
    """Half-sine bump [m] and its rate [m/s]."""
    phase = np.clip((t - start) / length, 0.0, 1.0)
    inside = (t >= start) & (t <= start + length)
    return height * np.sin(math.pi * phase), np.where(inside, height * math.pi / length * np.cos(math.pi * phase), 0.0)


def _posts(t: np.ndarray, starts: dict[str, float]) -> dict[str, np.ndarray]:
    inputs = {}
    for corner, start in starts.items():
        inputs[f"actuator_{corner}_displacement"], inputs[f"actuator_{corner}_velocity"] = _bump(t, start)
    return inputs


def test_static_loads_carry_the_whole_weight(params: VehicleParameters) -> None:
    car = build_full_vehicle(params, ALL_REFERENCE)
    y = car.output_vector(car.equilibrium(), car.input_vector({}))
    loads = {c: y[car.output_index(f"spindle_{c}_vertical_force")] for c in CORNERS}
    total = params.body.mass + 2 * (params.front.unsprung_mass + params.rear.unsprung_mass + params.lca.mass)
    assert sum(loads.values()) == pytest.approx(total * params.gravity, rel=1e-9)
    front_share = (loads["fl"] + loads["fr"]) / sum(loads.values())
    assert 0.55 < front_share < 0.62
    assert abs(y[car.output_index("body_heave")]) < 5e-3 and abs(y[car.output_index("body_roll")]) < 1e-12
    assert abs(y[car.output_index("lca_fl_angle")]) < math.radians(1.0)


def test_uniform_post_lift_translates_the_car_without_pitch_or_roll(car: LinearVehicle) -> None:
    rest = car.output_vector(car.equilibrium(), car.input_vector({}))
    lift = car.input_vector({f"actuator_{c}_displacement": 0.05 for c in CORNERS})
    lifted = car.output_vector(car.equilibrium(lift), lift)
    for i, name in enumerate(car.output_names):
        moved = 0.05 if name == "body_heave" or name.endswith("_displacement") and name.startswith("spindle_") else 0.0
        assert lifted[i] - rest[i] == pytest.approx(moved, abs=1e-10 * max(1.0, abs(rest[i]))), name


def test_uniform_heave_input_gives_no_roll_and_equal_sides(car: LinearVehicle) -> None:
    t = np.arange(600) * 1e-3
    result = simulate(car, _posts(t, {c: 0.05 for c in CORNERS}), SimulationSettings(dt=1e-3))
    assert np.max(np.abs(result["body_roll"])) < 1e-12
    for name in car.output_names:
        if "_fl_" in name or name.endswith("_fl"):
            right = name.replace("_fl", "_fr")
            scale = np.max(np.abs(result[name])) + 1e-9
            assert np.max(np.abs(result[name] - result[right])) < 1e-9 * scale, name


def test_front_input_delayed_to_the_rear_pitches_the_body(car: LinearVehicle, params: VehicleParameters) -> None:
    """Driving over a bump at 10 m/s: the rear posts repeat the front ones a wheelbase later."""
    t = np.arange(1500) * 1e-3
    delay = params.body.wheelbase / 10.0
    delayed = simulate(
        car, _posts(t, {"fl": 0.05, "fr": 0.05, "rl": 0.05 + delay, "rr": 0.05 + delay}), SimulationSettings(dt=1e-3)
    )
    together = simulate(car, _posts(t, {c: 0.05 for c in CORNERS}), SimulationSettings(dt=1e-3))
    pitch = np.max(np.abs(delayed["body_pitch"] - delayed["body_pitch"][0]))
    assert pitch > 2e-3  # a 20 mm bump under 2.75 m of wheelbase: several mrad
    assert pitch > 4 * np.max(np.abs(together["body_pitch"] - together["body_pitch"][0]))
    assert np.max(np.abs(delayed["body_roll"])) < 1e-12


def test_lca_angle_is_wheel_travel_over_arm_length(car: LinearVehicle, params: VehicleParameters) -> None:
    rest = car.output_vector(car.equilibrium(), car.input_vector({}))
    u = car.input_vector({"actuator_fl_displacement": 0.02})
    lifted = car.output_vector(car.equilibrium(u), u)
    d = {name: lifted[i] - rest[i] for i, name in enumerate(car.output_names)}
    lca = params.lca
    pivot = np.subtract(lca.front_bushing.position, lca.rear_bushing.position)
    arm = np.subtract(lca.ball_joint, lca.rear_bushing.position)
    length = np.linalg.norm(np.cross(pivot, arm)) / np.linalg.norm(pivot)
    assert 0.35 <= length <= 0.4
    x_ball, y_ball = lca.ball_joint[:2]
    body_above = d["body_heave"] + d["body_roll"] * y_ball - d["body_pitch"] * x_ball
    travel = d["spindle_fl_displacement"] - body_above
    assert travel > 0.002
    assert d["lca_fl_angle"] == pytest.approx(travel / length, rel=0.03)
    assert d["bushing_fl_front_axial_rotation"] == pytest.approx(d["lca_fl_angle"], rel=0.05)


def _port_laws(vehicle: LinearVehicle, params: VehicleParameters) -> list[tuple[int, int, int, float, float]]:
    """(force input, displacement output, rate output, stiffness, damping) of the linear reference law of every
    external damper and bushing port of `vehicle`."""
    rates = {
        f"damper_{c}": [(0.0, (params.front_damper if c[0] == "f" else params.rear_damper).damping)] for c in CORNERS
    }
    for corner in ("fl", "fr"):
        for position, b in (("front", params.lca.front_bushing), ("rear", params.lca.rear_bushing)):
            rates[f"bushing_{corner}_{position}"] = [
                (b.axial_stiffness, b.axial_damping),
                (b.radial_stiffness, b.radial_damping),
                (b.torsional_stiffness, b.torsional_damping),
                (b.conical_stiffness, b.conical_damping),
            ]
    laws = []
    for component, values in rates.items():
        for (force, disp, rate), (k, c) in zip(component_channels(component), values):
            if force in vehicle.input_names:
                laws.append((vehicle.input_index(force), vehicle.output_index(disp), vehicle.output_index(rate), k, c))
    return laws


def _close_loops(open_loop: LinearVehicle, params: VehicleParameters) -> np.ndarray:
    """A of the all-external model with every port fed by the linear reference law (force = k d + c v)."""
    a = open_loop.A.copy()
    for force, disp, rate, k, c in _port_laws(open_loop, params):
        assert not open_loop.D[disp].any() and not open_loop.D[rate].any()
        a += np.outer(open_loop.B[:, force], k * open_loop.C[disp] + c * open_loop.C[rate])
    return a


def test_external_ports_closed_by_the_reference_laws_equal_the_built_in_model(
    car: LinearVehicle, linear_params: VehicleParameters
) -> None:
    """Every force port and its deflection outputs are wired consistently: feeding back k d + c v rebuilds A exactly."""
    open_loop = build_full_vehicle(linear_params)
    closed = _close_loops(open_loop, linear_params)
    np.testing.assert_allclose(closed, car.A, rtol=0, atol=1e-9 * np.max(np.abs(car.A)))
    actuators = [car.input_index(n) for n in car.input_names]
    np.testing.assert_allclose(open_loop.B[:, : len(actuators)], car.B, rtol=0, atol=1e-12 * np.max(np.abs(car.B)))


@pytest.mark.parametrize("dt", [1e-3, 2e-3])
def test_stabilised_bushings_fed_their_linear_law_once_per_step_equal_the_built_in_model(
    car: LinearVehicle, linear_params: VehicleParameters, dt: float
) -> None:
    """A stabilised port fed the linear law's force at each step start is exact at any step (the held force plus the
    reference's change is the reference itself); the same exchange through plain external ports diverges."""
    dampers_in = {k: v for k, v in ALL_REFERENCE.items() if k.startswith("damper")}
    t = np.arange(int(round(0.5 / dt)) + 1) * dt
    inputs = _posts(t, {"fl": 0.02, "fr": 0.05, "rl": 0.2, "rr": 0.25})
    x0 = car.equilibrium()
    ref = simulate(car, inputs, SimulationSettings(dt=dt), x0=x0)["lca_fl_angle"]
    diverged = {}
    for choice in ("stabilised", "external"):
        ports = build_full_vehicle(
            linear_params, dampers_in | {n: choice for n in COMPONENTS if n.startswith("bushing")}
        )
        disc, laws = ports.discretise(dt), _port_laws(ports, linear_params)
        x, angle = x0.copy(), []
        for k in range(len(t)):
            u = ports.input_vector({name: values[k] for name, values in inputs.items()})
            y = ports.output_vector(x, u)
            for force, disp, rate, stiffness, damping in laws:
                u[force] = stiffness * y[disp] + damping * y[rate]
            angle.append(y[ports.output_index("lca_fl_angle")])
            x = disc.step(x, u)
            if not np.all(np.abs(x) < 1e3):  # metres and radians: far beyond any real motion
                break
        diverged[choice] = len(angle) < len(t)
        if choice == "stabilised":
            np.testing.assert_allclose(angle, ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))
    assert diverged == {"stabilised": False, "external": True}


def test_stabilised_ports_start_at_the_reference_models_equilibrium(
    car: LinearVehicle, linear_params: VehicleParameters
) -> None:
    stabilised = build_full_vehicle(
        linear_params, {n: "stabilised" if n.startswith("bushing") else v for n, v in ALL_REFERENCE.items()}
    )
    np.testing.assert_allclose(stabilised.equilibrium(), car.equilibrium(), rtol=1e-9, atol=1e-12)


def test_external_damper_gauss_seidel_converges(car: LinearVehicle, linear_params: VehicleParameters) -> None:
    """Four external dampers fed back c v once per step approach the built-in linear dampers as the step shrinks."""
    ports = build_full_vehicle(linear_params, {k: v for k, v in ALL_REFERENCE.items() if k.startswith("bushing")})
    x0 = car.equilibrium()
    errors = []
    for dt in (1e-3, 2.5e-4):
        t = np.arange(int(round(0.4 / dt)) + 1) * dt
        inputs = _posts(t, {"fl": 0.02, "fr": 0.05, "rl": 0.2, "rr": 0.25})
        ref = simulate(car, inputs, SimulationSettings(dt=dt), x0=x0)["spindle_fl_vertical_force"]
        disc = ports.discretise(dt)
        x, out = x0.copy(), []
        for k in range(len(t)):
            u = ports.input_vector({name: values[k] for name, values in inputs.items()})
            y = ports.output_vector(x, u)
            for c in CORNERS:
                damping = (linear_params.front_damper if c[0] == "f" else linear_params.rear_damper).damping
                u[ports.input_index(f"damper_{c}_force")] = damping * y[ports.output_index(f"damper_{c}_velocity")]
            out.append(ports.output_vector(x, u)[ports.output_index("spindle_fl_vertical_force")])
            x = disc.step(x, u)
        errors.append(np.max(np.abs(np.array(out) - ref)))
    assert errors[1] < 0.35 * errors[0]


def test_zoh_discretisation_equals_cont2discrete(car: LinearVehicle) -> None:
    dt = 1e-3
    disc = car.discretise(dt)
    ad, bd, *_ = cont2discrete((car.A, car.B, car.C, car.D), dt, "zoh")
    np.testing.assert_allclose(disc.Ad, ad, rtol=0, atol=1e-9)
    np.testing.assert_allclose(disc.Bd0, bd, rtol=0, atol=1e-9 * np.max(np.abs(bd)))


def _expected_unit(name: str, otherwise: str) -> str:
    """SI unit implied by a channel name's quantity suffix (the longest matching one)."""
    suffixes = {
        "angular_velocity": "rad/s", "displacement": "m", "velocity": "m/s", "force": "N", "torque": "N.m",
        "rotation": "rad", "angle": "rad",
    }  # fmt: skip
    for suffix, unit in suffixes.items():
        if name.endswith(suffix):
            return unit
    return otherwise


def test_ports_have_channel_names_and_units(params: VehicleParameters) -> None:
    car = build_full_vehicle(params)
    inputs, outputs = set(car.input_names), set(car.output_names)
    for c in CORNERS:
        assert {f"actuator_{c}_displacement", f"actuator_{c}_velocity", f"damper_{c}_force"} <= inputs
        assert {
            f"damper_{c}_displacement",
            f"damper_{c}_velocity",
            f"spindle_{c}_acceleration",
            f"spindle_{c}_vertical_force",
            f"body_acceleration_{c}",
        } <= outputs
    for c in ("fl", "fr"):
        assert f"lca_{c}_angle" in outputs
        for b in ("front", "rear"):
            stem = f"bushing_{c}_{b}"
            assert {f"{stem}_{q}" for q in ("axial_force", "radial_force", "axial_torque", "conical_torque")} <= inputs
            quantities = (
                "axial_displacement",
                "axial_velocity",
                "radial_displacement",
                "radial_velocity",
                "axial_rotation",
                "axial_angular_velocity",
                "conical_rotation",
                "conical_angular_velocity",
            )
            assert {f"{stem}_{q}" for q in quantities} <= outputs
    assert len(car.inputs) == 8 + 4 + 16 and len(car.outputs) == len(outputs)
    for port in car.inputs + car.outputs:
        assert port.unit in SI_UNITS and port.description, port
        assert port.unit == _expected_unit(port.name, port.unit), port


def test_reference_components_remove_their_inputs(params: VehicleParameters) -> None:
    car = build_full_vehicle(params, {"bushing_fl_front": "reference", "damper_rr": "reference"})
    assert not any(n.startswith("bushing_fl_front_") for n in car.input_names)
    assert "damper_rr_force" not in car.input_names and "damper_rl_force" in car.input_names
    assert car.feedback_names == ["damper_rr"]
    with pytest.raises(VehicleModelError, match="unknown component"):
        build_full_vehicle(params, {"bushing_fl_middle": "reference"})
    with pytest.raises(VehicleModelError, match="no unique static equilibrium"):
        build_full_vehicle(params).equilibrium()


@pytest.mark.slow
def test_monolithic_with_linear_laws_equals_the_built_in_model(
    car: LinearVehicle, linear_params: VehicleParameters
) -> None:
    """All 20 port channels closed by linear laws inside RK4 reproduce the exact all-reference model."""
    open_loop = build_full_vehicle(linear_params)
    laws = {}
    for corner in CORNERS:
        damper = linear_params.front_damper if corner[0] == "f" else linear_params.rear_damper
        laws |= linear_laws(f"damper_{corner}", (0.0,), (damper.damping,))
    for corner in ("fl", "fr"):
        for position, b in (("front", linear_params.lca.front_bushing), ("rear", linear_params.lca.rear_bushing)):
            stiffness = (b.axial_stiffness, b.radial_stiffness, b.torsional_stiffness, b.conical_stiffness)
            damping = (b.axial_damping, b.radial_damping, b.torsional_damping, b.conical_damping)
            laws |= linear_laws(f"bushing_{corner}_{position}", stiffness, damping)
    t = np.arange(151) * 1e-3
    inputs = _posts(t, {"fl": 0.01, "fr": 0.03, "rl": 0.05, "rr": 0.07})
    x0 = car.equilibrium()
    exact = simulate(car, inputs, SimulationSettings(dt=1e-3, hold="foh"), x0=x0)
    mono = simulate_monolithic(open_loop, laws, inputs, MonolithicSettings(sample_period=1e-3, step=5e-5), x0=x0)
    for name in (
        "spindle_fl_vertical_force",
        "lca_fr_angle",
        "bushing_fl_rear_radial_displacement",
        "body_acceleration_pitch",
    ):
        assert np.max(np.abs(mono[name] - exact[name])) < 1e-6 * np.max(np.abs(exact[name] - exact[name][0])), name


def test_monolithic_truth_reference_runs_and_loads_the_bushings(params: VehicleParameters) -> None:
    car = build_full_vehicle(params)
    forces = [n for n in car.input_names if not n.startswith("actuator")]
    t = np.arange(101) * 1e-3
    x0 = build_full_vehicle(params, ALL_REFERENCE).equilibrium()
    result = simulate_monolithic(
        car,
        truth_laws(forces),
        _posts(t, {"fl": 0.0, "fr": 0.0, "rl": 0.0, "rr": 0.0}),
        MonolithicSettings(sample_period=1e-3),
        x0=x0,
    )
    assert all(np.all(np.isfinite(result[n])) for n in forces)
    assert np.max(np.abs(result["bushing_fl_front_axial_torque"])) > 0.1
    assert (
        np.max(np.abs(result["bushing_fl_front_radial_force"] - result["bushing_fr_front_radial_force"]))
        < 1e-6 * np.max(np.abs(result["bushing_fl_front_radial_force"])) + 1e-9
    )
