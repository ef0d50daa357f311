"""Quarter car: statics, natural frequencies, exact discretisation, reference dampers and external damper coupling."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import cont2discrete

from nnfmu.vehicle.dynamics import (
    LinearLaw,
    MonolithicSettings,
    ParameterError,
    QuarterCarParameters,
    SimulationSettings,
    VehicleModelError,
    VehicleParameters,
    build_quarter_car,
    simulate,
    simulate_monolithic,
    truth_laws,
)

SI_UNITS = {"m", "m/s", "m/s^2", "N", "N.m", "rad", "rad/s", "rad/s^2"}


@pytest.fixture(scope="module")
def vehicle() -> VehicleParameters:
    return VehicleParameters.load()


@pytest.fixture(scope="module")
def params() -> QuarterCarParameters:
    """The quarter car of the packaged sedan's front-left corner (what `nnfmu vehicle build quarter-car` builds)."""
    return QuarterCarParameters.load()


def _linear_damper(params: QuarterCarParameters) -> QuarterCarParameters:
    return replace(params, damper=replace(params.damper, model="linear"))


def _road(t: np.ndarray) -> np.ndarray:
    """A smooth post displacement [m]: two sines, 10 mm and 2 mm."""
    return 0.01 * np.sin(2 * math.pi * 1.3 * t) + 0.002 * np.sin(2 * math.pi * 11.0 * t)


def _road_rate(t: np.ndarray) -> np.ndarray:
    return 0.01 * 2 * math.pi * 1.3 * np.cos(2 * math.pi * 1.3 * t) + 0.002 * 2 * math.pi * 11.0 * np.cos(
        2 * math.pi * 11.0 * t
    )


def test_default_parameters_are_a_midsize_car(vehicle: VehicleParameters) -> None:
    assert 1200 <= vehicle.body.mass <= 1400
    assert 2000 <= vehicle.body.pitch_inertia <= 2500 and 500 <= vehicle.body.roll_inertia <= 600
    assert 25e3 <= vehicle.front.spring_rate <= 35e3 and 200e3 <= vehicle.front.tyre_stiffness <= 250e3


def test_design_position_is_the_static_equilibrium(params: QuarterCarParameters) -> None:
    car = build_quarter_car(params)
    x = car.equilibrium()
    np.testing.assert_allclose(x, 0.0, atol=1e-12)
    y = car.output_vector(x, car.input_vector({}))
    weight = (params.sprung_mass + params.unsprung_mass) * params.gravity
    assert y[car.output_index("spindle_vertical_force")] == pytest.approx(weight, rel=1e-12)


def test_gravity_alone_compresses_the_spring_by_mg_over_k(params: QuarterCarParameters) -> None:
    """Without the spring and tyre preloads the masses sag: spring by m_s g / k, tyre by (m_s + m_u) g / k_t."""
    car = build_quarter_car(params)
    x = np.linalg.solve(car.A, -car.gravity)
    y = car.output_vector(x, car.input_vector({}))
    m_s, g = params.sprung_mass, params.gravity
    body, spindle = y[car.output_index("body_displacement")], y[car.output_index("spindle_displacement")]
    assert body - spindle == pytest.approx(-m_s * g / params.wheel_rate, rel=1e-9)
    assert spindle == pytest.approx(-(m_s + params.unsprung_mass) * g / params.tyre_stiffness, rel=1e-9)


def test_natural_frequencies_match_the_two_mass_formula(params: QuarterCarParameters) -> None:
    car = build_quarter_car(replace(params, tyre_damping=0.0))
    body_hz, hop_hz = car.natural_frequencies()
    assert 1.0 <= body_hz <= 1.5 and 10.0 <= hop_hz <= 15.0
    m_s, m_u = params.sprung_mass, params.unsprung_mass
    k, k_t = params.wheel_rate, params.tyre_stiffness
    # det(K - w^2 M) = 0 for M = diag(m_s, m_u), K = [[k, -k], [-k, k + k_t]]
    a, b, c = m_s * m_u, -(k * m_u + (k + k_t) * m_s), k * k_t
    w2 = np.sort(np.roots([a, b, c]).real)
    np.testing.assert_allclose([body_hz, hop_hz], np.sqrt(w2) / (2 * math.pi), rtol=1e-9)


def test_zoh_discretisation_equals_cont2discrete(params: QuarterCarParameters) -> None:
    car = build_quarter_car(_linear_damper(params), {"damper": "reference"})
    dt = 2e-3
    disc = car.discretise(dt, "zoh")
    ad, bd, *_ = cont2discrete(
        (car.A, np.hstack([car.B, car.f[:, None]]), car.C, np.zeros((car.C.shape[0], car.B.shape[1] + 1))), dt, "zoh"
    )
    np.testing.assert_allclose(disc.Ad, ad, rtol=0, atol=1e-9)
    np.testing.assert_allclose(disc.Bd0, bd[:, :-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(disc.fd, bd[:, -1], rtol=0, atol=1e-9)
    assert not disc.Bd1.any()


@pytest.mark.slow
@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_discrete_simulation_equals_a_fine_rk45_solution(params: QuarterCarParameters, hold: str) -> None:
    """ZOH is exact for held inputs, FOH for inputs linear between samples: both against RK45 at tight tolerances."""
    car = build_quarter_car(_linear_damper(params), {"damper": "reference"})
    dt, n = 5e-3, 201
    t = np.arange(n) * dt
    inputs = {"actuator_fl_displacement": _road(t), "actuator_fl_velocity": _road_rate(t)}
    result = simulate(car, inputs, SimulationSettings(dt=dt, hold=hold), x0=np.zeros(4))
    u = np.array([car.input_vector({k: v[i] for k, v in inputs.items()}) for i in range(n)])

    def held(s: float) -> np.ndarray:
        k = min(int(s / dt + 1e-9), n - 1)
        if hold == "zoh":
            return u[k]
        k = min(k, n - 2)
        return u[k] + (u[k + 1] - u[k]) * (s - t[k]) / dt

    states = [np.zeros(4)]
    for k in range(n - 1):  # integrate step by step so the solver never straddles an input kink
        sol = solve_ivp(
            lambda s, x: car.A @ x + car.B @ held(min(s, t[k + 1] - 1e-15)) + car.f,
            (t[k], t[k + 1]),
            states[-1],
            rtol=1e-11,
            atol=1e-14,
        )
        states.append(sol.y[:, -1])
    ref = np.array([car.C @ x + car.D @ uk + car.e for x, uk in zip(states, u)])
    for i, name in enumerate(car.output_names):
        scale = np.max(np.abs(ref[:, i] - ref[0, i])) + 1e-12
        assert np.max(np.abs(result[name] - ref[:, i])) <= 1e-6 * scale, name


@pytest.mark.slow
def test_spline_damper_sub_stepping_converges(params: QuarterCarParameters) -> None:
    """With the nonlinear spline damper built in, the predictor-corrector error falls with the square of the
    sub-step."""
    car = build_quarter_car(params, {"damper": "reference"})
    dt, n = 2e-3, 400
    t = np.arange(n) * dt
    inputs = {"actuator_fl_displacement": _road(t), "actuator_fl_velocity": _road_rate(t)}
    fine = simulate(car, inputs, SimulationSettings(dt=dt, hold="foh", max_substep=dt / 64))["damper_velocity"]
    errors = [
        np.max(
            np.abs(
                simulate(car, inputs, SimulationSettings(dt=dt, hold="foh", max_substep=dt / s))["damper_velocity"]
                - fine
            )
        )
        for s in (2, 4, 8)
    ]
    assert errors[0] > errors[1] > errors[2] > 0.0
    assert errors[2] < 0.1 * errors[0]  # second order: 1/16 for a sub-step 4 times smaller
    assert errors[2] < 1e-3 * np.max(np.abs(fine))


@pytest.mark.slow
def test_a_linear_spline_reproduces_the_linear_damper(params: QuarterCarParameters) -> None:
    c = params.damper.damping
    spline = replace(params.damper, model="spline", velocity=(-2.0, 0.0, 2.0), force=(-2 * c, 0.0, 2 * c))
    t = np.arange(300) * 2e-3
    inputs = {"actuator_fl_displacement": _road(t), "actuator_fl_velocity": _road_rate(t)}
    settings = SimulationSettings(dt=2e-3, max_substep=2e-5)
    nonlinear = simulate(build_quarter_car(replace(params, damper=spline), {"damper": "reference"}), inputs, settings)
    linear = simulate(build_quarter_car(_linear_damper(params), {"damper": "reference"}), inputs, settings)
    scale = np.max(np.abs(linear["body_acceleration"]))
    assert np.max(np.abs(nonlinear["body_acceleration"] - linear["body_acceleration"])) < 1e-3 * scale


def _gauss_seidel(params: QuarterCarParameters, dt: float, duration: float, x0: np.ndarray) -> np.ndarray:
    """Co-simulate the external damper port with an 'FMU' force = c * velocity, exchanged once per step."""
    car = build_quarter_car(params)
    c = params.damper.damping
    disc = car.discretise(dt)
    x = x0
    iv, iforce = car.output_index("damper_velocity"), car.input_index("damper_force")
    out = []
    for k in range(int(round(duration / dt)) + 1):
        t = k * dt
        u = car.input_vector(
            {"actuator_fl_displacement": _road(np.array(t)), "actuator_fl_velocity": _road_rate(np.array(t))}
        )
        u[iforce] = c * car.output_vector(x, u)[iv]
        out.append(car.output_vector(x, u)[car.output_index("body_acceleration")])
        x = disc.step(x, u)
    return np.array(out)


def test_external_damper_port_converges_to_the_built_in_linear_damper(params: QuarterCarParameters) -> None:
    duration = 1.0
    steps = (1e-3, 5e-4, 2.5e-4)
    errors = []
    for dt in steps:
        t = np.arange(int(round(duration / dt)) + 1) * dt
        reference = build_quarter_car(_linear_damper(params), {"damper": "reference"})
        x0 = reference.equilibrium()
        inputs = {"actuator_fl_displacement": _road(t), "actuator_fl_velocity": _road_rate(t)}
        ref = simulate(reference, inputs, SimulationSettings(dt=dt), x0=x0)
        errors.append(np.max(np.abs(_gauss_seidel(params, dt, duration, x0) - ref["body_acceleration"])))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] / errors[0] < 0.35  # first order in the step: about 1/4 for a step 4 times smaller


def test_every_port_has_a_unit_and_a_description(params: QuarterCarParameters) -> None:
    car = build_quarter_car(params)
    assert car.input_names == ["actuator_fl_displacement", "actuator_fl_velocity", "damper_force"]
    for port in car.inputs + car.outputs:
        assert port.unit in SI_UNITS and port.description, port


def test_body_velocity_is_the_rate_of_body_displacement_and_ties_to_the_stroke(params: QuarterCarParameters) -> None:
    """The skyhook sensor: body_velocity integrates to body_displacement along a simulated drive, and the stroke rate
    is the motion ratio times body minus spindle velocity (rebound positive), whatever the state."""
    car = build_quarter_car(_linear_damper(params), {"damper": "reference"})
    dt, n = 1e-3, 2001
    t = np.arange(n) * dt
    inputs = {"actuator_fl_displacement": _road(t), "actuator_fl_velocity": _road_rate(t)}
    result = simulate(car, inputs, SimulationSettings(dt=dt, hold="foh"), x0=np.zeros(4))
    integrated = np.concatenate(
        [[0.0], np.cumsum(0.5 * (result["body_velocity"][1:] + result["body_velocity"][:-1])) * dt]
    )
    scale = np.ptp(result["body_displacement"])
    assert scale > 1e-3 and np.max(np.abs(integrated - result["body_displacement"])) < 1e-4 * scale
    x = np.random.default_rng(0).standard_normal(4)
    y = car.output_vector(x, car.input_vector({}))
    spindle_rate = x[3]  # states [body, spindle, body rate, spindle rate]
    assert y[car.output_index("body_velocity")] == x[2]
    assert y[car.output_index("damper_velocity")] == pytest.approx(
        params.damper_motion_ratio * (y[car.output_index("body_velocity")] - spindle_rate), rel=1e-12
    )


def test_reference_damper_removes_the_force_input(params: QuarterCarParameters) -> None:
    assert "damper_force" not in build_quarter_car(params, {"damper": "reference"}).input_names
    with pytest.raises(VehicleModelError, match="unknown component"):
        build_quarter_car(params, {"dampr": "reference"})
    with pytest.raises(VehicleModelError, match="no input port 'damper_forc'"):
        build_quarter_car(params).input_index("damper_forc")


def test_bad_parameter_files_name_the_file_and_key(tmp_path: Path, vehicle: VehicleParameters) -> None:
    text = Path(vehicle.source).read_text(encoding="utf-8")
    cases = {
        "negative.toml": (
            text.replace("spring_rate = 30000.0", "spring_rate = -30000.0"),
            r"front\.spring_rate = -30000\.0 must be > 0",
        ),
        "typo.toml": (text.replace("tyre_damping = 150.0", "tyre_dampng = 150.0", 1), r"front\.tyre_damping"),
        "order.toml": (
            text.replace("velocity = [-1.0, -0.5", "velocity = [-0.4, -0.5", 1),
            r"damper\.front\.velocity must increase",
        ),
    }
    for name, (content, message) in cases.items():
        path = tmp_path / name
        path.write_text(content, encoding="utf-8")
        with pytest.raises(ParameterError, match=message) as info:
            VehicleParameters.load(path)
        assert str(path) in str(info.value)


def test_monolithic_rk4_with_a_linear_law_equals_the_exact_solution(params: QuarterCarParameters) -> None:
    """Two independent solvers: RK4 at 0.1 ms with the damper law closing the port vs the exact FOH discretisation."""
    reference = build_quarter_car(_linear_damper(params), {"damper": "reference"})
    t = np.arange(501) * 1e-3
    inputs = {"actuator_fl_displacement": _road(t), "actuator_fl_velocity": _road_rate(t)}
    x0 = reference.equilibrium()
    exact = simulate(reference, inputs, SimulationSettings(dt=1e-3, hold="foh"), x0=x0)
    law = {"damper_force": LinearLaw(0.0, params.damper.damping)}
    mono = simulate_monolithic(build_quarter_car(params), law, inputs, MonolithicSettings(sample_period=1e-3), x0=x0)
    for name in ("body_acceleration", "damper_velocity", "spindle_vertical_force"):
        assert np.max(np.abs(mono[name] - exact[name])) < 1e-8 * np.max(np.abs(exact[name])), name


def test_monolithic_with_the_truth_damper_differs_from_the_spline_baseline(params: QuarterCarParameters) -> None:
    """The truth damper (hysteresis, friction) gives a plausible, different force from the spline baseline."""
    t = np.arange(501) * 1e-3
    inputs = {"actuator_fl_displacement": _road(t), "actuator_fl_velocity": _road_rate(t)}
    car = build_quarter_car(params)
    x0 = build_quarter_car(params, {"damper": "reference"}).equilibrium()
    truth = simulate_monolithic(
        car, truth_laws(["damper_force"]), inputs, MonolithicSettings(sample_period=1e-3), x0=x0
    )
    spline = simulate(build_quarter_car(params, {"damper": "reference"}), inputs, SimulationSettings(dt=1e-3), x0=x0)
    force = truth["damper_force"]
    assert np.all(np.isfinite(force)) and 100.0 < np.max(np.abs(force)) < 5000.0
    relative = np.max(np.abs(truth["damper_velocity"] - spline["damper_velocity"])) / np.max(
        np.abs(spline["damper_velocity"])
    )
    assert 1e-3 < relative < 0.5


def test_a_parameter_file_nested_too_deeply_is_refused_naming_the_file(tmp_path) -> None:
    path = tmp_path / "deep.toml"
    path.write_text("body = " + "{ a = " * 20_000 + "\n", encoding="utf-8")
    with pytest.raises(ParameterError, match=r"deep\.toml.*nested too deeply"):
        VehicleParameters.load(path)
