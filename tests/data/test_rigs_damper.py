"""Damper dyno simulator: physics of each effect against analytic results, and the rig's files and seeds."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nnfmu.data.rigs import DamperParams, DamperTruth, RigOptions, ValveSide, simulate_rig, write_rig
from nnfmu.data.rigs.excitation import SineLevel, sine_level

DT = 0.25e-3


def sine(amplitude: float, frequency: float, cycles: float, dt: float = DT):
    t = np.arange(int(round(cycles / frequency / dt)) + 1) * dt
    w = 2 * math.pi * frequency
    return t, amplitude * np.sin(w * t), amplitude * w * np.cos(w * t), -amplitude * w * w * np.sin(w * t)


def fundamental(signal: np.ndarray, t: np.ndarray, frequency: float) -> complex:
    """Complex amplitude of the `frequency` component over whole cycles (signal ≈ Re(c·e^{iωt}))."""
    e = np.exp(-2j * math.pi * frequency * t[:-1])
    return 2 * np.mean(signal[:-1] * e)


def test_pure_friction_dissipates_four_coulomb_force_times_amplitude_per_cycle():
    params = DamperParams()
    amplitude, frequency, cycles = 0.02, 2.0, 3
    t, x, v, a = sine(amplitude, frequency, cycles)
    with_friction, _ = DamperTruth(params, ("seal_friction",)).simulate(DT, x, v, a)
    without, _ = DamperTruth(params, ()).simulate(DT, x, v, a)
    friction = with_friction - without
    energy = np.trapezoid(friction * v, t) / cycles
    assert energy == pytest.approx(4 * params.seal_friction * amplitude, rel=0.02)


def test_rebound_force_exceeds_jounce_force_at_the_same_speed():
    truth = DamperTruth(DamperParams(), ())
    speeds = np.array([0.05, 0.1, 0.3, 0.6, 1.0, 1.5])
    rebound, jounce = truth.characteristic(speeds), -truth.characteristic(-speeds)
    assert np.all(jounce > 0)
    assert np.all(rebound > 1.8 * jounce)
    assert 2000 < rebound[-1] < 5000  # a few kN at 1.5 m/s


def test_characteristic_is_digressive_above_the_knee():
    params = DamperParams()
    truth = DamperTruth(params, ())
    for sign, side in ((1, params.rebound), (-1, params.jounce)):
        low, high = sign * np.array([0.4, 0.6]) * side.knee_velocity, sign * np.array([3.0, 4.0]) * side.knee_velocity
        below = np.diff(truth.characteristic(low))[0] / np.diff(low)[0]
        above = np.diff(truth.characteristic(high))[0] / np.diff(high)[0]
        assert below > 3 * above > 0
        assert below == pytest.approx(truth.valve_slope(float(low.mean())), rel=0.02)


def test_inverse_characteristic_returns_the_velocity():
    truth = DamperTruth(DamperParams(), ())
    for v in (-1.5, -0.2, -0.01, 0.0, 1e-4, 0.15, 0.7, 1.5):
        assert truth.valve_velocity(float(truth.characteristic(v))) == pytest.approx(v, abs=1e-9)


def test_hysteresis_lags_like_a_series_spring_and_dashpot():
    """Below the knee the valve is a dashpot c in series with k_s: the force lags the velocity by atan(ω c / k_s)."""
    side = ValveSide(c_low=8000.0, c_high=1300.0, knee_velocity=0.15, rounding=1.0)
    params = DamperParams(rebound=side, jounce=side)
    truth = DamperTruth(params, ("hysteresis",))
    lags = []
    for frequency in (2.0, 8.0):
        t, x, v, a = sine(0.02 / (2 * math.pi * frequency), frequency, 6)
        force, _ = truth.simulate(DT, x, v, a)
        last = t >= 3 / frequency  # skip the start-up transient
        tt = t[last] - t[last][0]
        lag = np.angle(fundamental(v[last], tt, frequency)) - np.angle(fundamental(force[last], tt, frequency))
        expected = math.atan(2 * math.pi * frequency * side.c_low / params.series_stiffness)
        assert lag == pytest.approx(expected, rel=0.03)
        loop_area = abs(np.trapezoid(force[last], v[last]))
        assert loop_area > 0.05 * np.ptp(force[last]) * np.ptp(v[last])
        lags.append(lag)
    assert lags[1] > lags[0] > 0


def test_without_hysteresis_the_force_velocity_curve_has_no_loop():
    t, x, v, a = sine(0.01, 4.0, 2)
    force, _ = DamperTruth(DamperParams(), ()).simulate(DT, x, v, a)
    assert abs(np.trapezoid(force, v)) < 1e-3 * np.ptp(force) * np.ptp(v)


@pytest.mark.slow
def test_rig_integration_matches_an_independent_stiff_solver():
    """The dyno's step (0.5 ms, a ramped sine as the rig drives it) against Radau on `derivatives` at 1e-9."""
    truth = DamperTruth(DamperParams(), ("hysteresis", "temperature"))
    rate = 2000.0
    motion = sine_level(SineLevel(0.025, 8.0), 3, rate)
    x, v, a = motion.x, motion.v, motion.a
    t = np.arange(len(x)) / rate
    force, states = truth.simulate(1 / rate, x, v, a)
    ref = solve_ivp(
        lambda tt, s: truth.derivatives(tt, s, np.interp(tt, t, x), np.interp(tt, t, v)),
        (0, t[-1]),
        truth.initial_state(),
        method="Radau",
        t_eval=t,
        rtol=1e-9,
        atol=1e-6,
        max_step=1 / rate,
    )
    reference = truth.force(ref.y.T, x, v, a)
    assert np.max(np.abs(force - reference)) < 2e-3 * np.max(np.abs(reference))
    assert states[-1, 1] == pytest.approx(ref.y[1, -1], abs=1e-3)


def test_gas_force_is_the_preload_at_mid_stroke_and_rises_with_compression():
    params = DamperParams()
    options = RigOptions(duration=16.0, noise=0.0, excitation="sine", effects=("gas_force",))
    on = simulate_rig("damper", options, params).measurement
    off = simulate_rig("damper", replace(options, effects=()), params).measurement
    push = off["force"] - on["force"]  # the gas pushes the rod out: less tension
    slope, intercept = np.polyfit(on["displacement"], push, 1)
    assert intercept == pytest.approx(params.gas_preload, rel=1e-6)
    assert -slope == pytest.approx(params.gas_rate, rel=1e-6)
    assert 150 <= params.gas_preload <= 400 and 500 <= params.gas_rate <= 2000


def test_temperature_rises_and_the_peak_force_fades_by_the_fade_coefficient():
    params = DamperParams()
    truth = DamperTruth(params, ("temperature",))
    frequency = 3.0
    t, x, v, a = sine(0.025, frequency, 180, dt=1e-3)
    force, states = truth.simulate(1e-3, x, v, a)
    temp = states[:, 0]
    rise = temp[-1] - temp[0]
    assert 5 < rise < 60
    period = int(round(1 / frequency / 1e-3))
    first, last = force[:period].max(), force[-period:].max()
    expected = math.exp(-params.fade * (temp[-period:].mean() - temp[:period].mean()))
    assert last / first == pytest.approx(expected, rel=2e-3)
    dissipated = np.trapezoid(force * v, t)
    lost = np.trapezoid(params.heat_conductance * (temp - params.ambient_temperature), t)
    assert params.heat_capacity * rise + lost == pytest.approx(dissipated, rel=0.01)


def test_inertia_adds_mass_times_acceleration():
    params = DamperParams()
    t, x, v, a = sine(0.025, 9.0, 2)
    on, _ = DamperTruth(params, ("inertia",)).simulate(DT, x, v, a)
    off, _ = DamperTruth(params, ()).simulate(DT, x, v, a)
    np.testing.assert_allclose(on - off, params.moving_mass * a, atol=1e-9)


def test_lab_run_records_the_standard_and_high_speed_velocities_and_temperature():
    run = simulate_rig("damper", RigOptions(duration=40.0, effects=("temperature",)))
    m = run.measurement
    assert set(m.names) == {"displacement", "velocity", "force", "temperature"}
    assert m.units == {"displacement": "m", "velocity": "m/s", "force": "N", "temperature": "K"}
    assert m.sample_period == pytest.approx(1e-3)
    assert len(m) == 40000
    levels = run.truth["excitation"]["parts"][0]["levels"]
    standard = [0.05, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5]
    assert [lv["peak_rate"] for lv in levels] == pytest.approx(standard + [2.0, 2.5, 3.0])  # a pothole's 2-3 m/s
    assert max(lv["amplitude"] for lv in levels) <= 0.025 + 1e-12  # the high speeds by frequency, not by stroke
    assert np.max(np.abs(m["velocity"])) == pytest.approx(3.0, abs=0.02)
    assert m["temperature"][-500:].mean() > m["temperature"][:500].mean() + 2


def test_default_effects_and_unknown_names():
    run = simulate_rig("damper", RigOptions(duration=2.0, excitation="random"))
    assert run.truth["effects"] == ["hysteresis", "seal_friction", "inertia"]
    assert "temperature" not in run.measurement
    with pytest.raises(ValueError, match=r"'viscous'.*hysteresis, gas_force, seal_friction, temperature, inertia"):
        simulate_rig("damper", RigOptions(effects=("viscous",)))
    with pytest.raises(ValueError, match=r"'strut'.*damper, bushing"):
        simulate_rig("strut", RigOptions())
    with pytest.raises(ValueError, match=r"'lab' excitation of 10 s: the sine series needs at least"):
        simulate_rig("damper", RigOptions(duration=10.0))
    with pytest.raises(ValueError, match=r"sample_rate must be at least 100 Hz"):
        simulate_rig("damper", RigOptions(sample_rate=50.0))
    with pytest.raises(ValueError, match=r"'chirp'"):
        simulate_rig("damper", RigOptions(excitation="chirp"))


def test_noise_is_realistic_and_zero_noise_is_exact():
    options = RigOptions(duration=3.0, excitation="random", effects=())
    noisy = simulate_rig("damper", options).measurement
    exact = simulate_rig("damper", replace(options, noise=0.0)).measurement
    error = noisy["force"] - exact["force"]
    assert 5 < np.std(error) < 15  # 0.1 % of a 10 kN load cell
    assert simulate_rig("damper", options).truth["sensors"]["force"]["noise_rms"] == pytest.approx(10.0)
    exact_force = DamperTruth(DamperParams(), ()).characteristic(exact["velocity"])
    np.testing.assert_allclose(exact["force"], exact_force, rtol=1e-12, atol=1e-9)


def test_same_seed_same_data_other_seed_other_data():
    options = RigOptions(duration=3.0, excitation="random")
    first, again = simulate_rig("damper", options), simulate_rig("damper", options)
    other = simulate_rig("damper", replace(options, seed=1))
    for name in first.measurement.names:
        np.testing.assert_array_equal(first.measurement[name], again.measurement[name])
    assert not np.allclose(first.measurement["force"], other.measurement["force"])
    assert first.truth == again.truth


@pytest.mark.parametrize("suffix", [".csv", ".mf4"])
def test_write_rig_puts_the_truth_beside_the_data(tmp_path, suffix):
    from nnfmu.data import load_measurement

    options = RigOptions(duration=2.0, excitation="random", effects=("hysteresis", "temperature"))
    data, truth_file = write_rig("damper", tmp_path / f"dyno{suffix}", options)
    assert data == tmp_path / f"dyno{suffix}" and truth_file == tmp_path / "dyno.truth.json"
    assert json.loads(truth_file.read_text()) == simulate_rig("damper", options).truth
    loaded = load_measurement(data)
    run = simulate_rig("damper", options).measurement
    for name in run.names:
        np.testing.assert_allclose(loaded[name], run[name], rtol=1e-6, atol=1e-9)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([data.name, truth_file.name])
