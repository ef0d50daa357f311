"""Bushing rig simulator: progressive spring, Maxwell dynamic stiffness, Berg friction, drives, seeds and files."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nnfmu.data.rigs import BUSHING_CHANNELS, BushingChannelTruth, BushingParams, RigOptions, simulate_rig, write_rig
from nnfmu.data.rigs.options import SCHEDULE_DURATION, resolve_duration
from nnfmu.errors import SettingsError
from nnfmu.physics.bushing import iwan_elements

RATE = 2000.0


def sine(amplitude: float, frequency: float, cycles: int):
    t = np.arange(int(round(cycles / frequency * RATE)) + 1) / RATE
    return t, amplitude * np.sin(2 * math.pi * frequency * t)


def loop_area(force: np.ndarray, x: np.ndarray) -> float:
    return abs(float(np.trapezoid(force, x)))


def test_secant_stiffness_grows_with_amplitude():
    params = BushingParams()
    for key in ("axial", "radial", "axial_rotation", "conical_rotation"):
        truth = BushingChannelTruth(getattr(params, key), effects=())
        amplitudes = np.array([0.2, 0.6, 1.2]) * (1.2e-3 if "rotation" not in key else 0.05)
        secant = []
        for amplitude in amplitudes:
            _, x = sine(amplitude, 1.0, 1)
            force, _ = truth.simulate(1 / RATE, x)
            secant.append(force.max() / amplitude)
        assert secant[0] < secant[1] < secant[2]
        assert secant[0] == pytest.approx(getattr(params, key).stiffness, rel=0.05)


def test_maxwell_dynamic_stiffness_and_loss_angle_match_the_analytic_complex_stiffness():
    params = replace(BushingParams().radial, cubic_stiffness=0.0)
    truth = BushingChannelTruth(params, effects=("viscoelastic",))
    magnitudes, angles = [], []
    for frequency in (1.0, 5.0, 20.0):
        t, x = sine(1e-4, frequency, 12)
        force, _ = truth.simulate(1 / RATE, x)
        settled = t >= 6 / frequency  # the 100 ms branch has decayed by then
        tt = t[settled][:-1] - t[settled][0]
        e = np.exp(-2j * math.pi * frequency * tt)
        measured = np.sum(force[settled][:-1] * e) / np.sum(x[settled][:-1] * e)
        jw = 2j * math.pi * frequency
        expected = params.stiffness + sum(
            k * jw * tau / (1 + jw * tau) for k, tau in zip(params.maxwell_stiffness, params.maxwell_time)
        )
        assert measured == pytest.approx(expected, rel=2e-3)
        magnitudes.append(abs(measured))
        angles.append(math.degrees(np.angle(measured)))
    assert magnitudes[0] < magnitudes[1] < magnitudes[2]
    assert all(1.0 < a < 20.0 for a in angles)  # rubber loss angles of a few degrees


def test_berg_friction_follows_the_virgin_curve_and_its_loop_grows_with_amplitude():
    params = BushingParams().radial
    stiffness, slip = iwan_elements(params.friction_max, params.friction_x2)
    assert np.all(stiffness > 0)
    for d in (0.5, 1.0, 4.0):
        virgin = np.sum(stiffness * np.minimum(d * params.friction_x2, slip / stiffness))
        assert virgin == pytest.approx(params.friction_max * d / (1 + d), rel=0.02)
    truth = BushingChannelTruth(params, effects=("friction",))
    elastic = BushingChannelTruth(params, effects=())
    areas = []
    for amplitude in np.array([0.5, 2.0, 8.0, 100.0]) * params.friction_x2:
        _, x = sine(amplitude, 1.0, 2)
        half = len(x) // 2  # the second cycle: a steady loop
        friction = truth.simulate(1 / RATE, x)[0] - elastic.simulate(1 / RATE, x)[0]
        areas.append(loop_area(friction[half:], x[half:]))
    assert areas[0] < areas[1] < areas[2] < areas[3]
    assert 0.85 < areas[3] / (4 * params.friction_max * 100 * params.friction_x2) < 1.0


def test_exact_update_matches_integrating_the_derivatives():
    params = BushingParams().axial
    truth = BushingChannelTruth(params)
    t, x = sine(2e-3, 5.0, 2)
    force, _ = truth.simulate(1 / RATE, x)
    v = np.gradient(x, t)
    ref = solve_ivp(
        lambda tt, s: truth.derivatives(tt, s, np.interp(tt, t, x), np.interp(tt, t, v)),
        (0, t[-1]),
        truth.initial_state(),
        t_eval=t,
        max_step=0.25 / RATE,
        rtol=1e-8,
        atol=1e-6,
    )
    reference = truth.force(ref.y.T, x)
    assert np.max(np.abs(force - reference)) < 5e-3 * np.max(np.abs(reference))


def test_lab_schedule_is_the_stiffness_series_then_random_on_the_target_spectrum_beyond_the_vehicle_range():
    from scipy.signal import welch

    from nnfmu.data.rigs import BushingRig

    rig = BushingRig()
    run = simulate_rig("bushing", RigOptions(duration=60.0, noise=0.0, effects=()))
    m = run.measurement
    for key, channel in BUSHING_CHANNELS.items():
        series, random = run.truth["excitation"]["drives"][key]["parts"]
        assert (series["type"], series["start_s"], random["end_s"]) == ("sine series", 0.0, 60.0)
        assert random["start_s"] == series["end_s"] == pytest.approx(26.601)
        expected = {(f, a * rig.vehicle_range[key]) for f in rig.sine_frequencies for a in rig.sine_amplitudes}
        got = {(lv["frequency_Hz"], lv["amplitude"]) for lv in series["levels"]}
        assert got == expected and {lv["cycles"] for lv in series["levels"]} == {rig.lab_sine_cycles}
        position = m[channel.position]
        start = int(round(random["start_s"] * 1000.0))
        assert np.max(np.abs(position[:start])) == pytest.approx(rig.vehicle_range[key], rel=1e-3)
        assert np.max(np.abs(position)) == pytest.approx(rig.lab_margin * rig.vehicle_range[key], rel=1e-9)
        f, psd = welch(position[start:], fs=1000.0, nperseg=4096)
        target = rig.lab_shape.psd(f)
        bands = np.geomspace(1.0, 35.0, 12)  # third-octave-like bands well inside 0.5-40 Hz
        ratios = []
        for lo, hi in zip(bands[:-1], bands[1:]):
            inside = (f >= lo) & (f < hi)
            ratios.append(np.mean(psd[inside]) / np.mean(target[inside]))
        db = 10 * np.log10(np.array(ratios) / np.median(ratios))
        assert np.max(np.abs(db)) < 1.5, f"{channel.position}: band levels off the target by {db.round(2)} dB"
        outside = f > 60.0
        assert np.max(psd[outside]) < 1e-6 * np.max(psd)
        assert random["peak_over_vehicle_range"] == rig.lab_margin


def test_the_lab_schedules_stiffness_series_is_found_as_sine_tests_in_the_recorded_positions():
    """`nnfmu characterise --measured` reads a lab record's series: every level found (3 cycles at full amplitude
    between the ramps) through the transducers' noise, and none in the random part."""
    from nnfmu.workflows.characterise.detect import find_sine_tests

    run = simulate_rig("bushing", RigOptions(duration=60.0, seed=0))
    time = np.arange(len(run.measurement[BUSHING_CHANNELS["axial"].position])) / 1000.0
    for key, channel in BUSHING_CHANNELS.items():
        series, random = run.truth["excitation"]["drives"][key]["parts"]
        found = find_sine_tests(time, np.asarray(run.measurement[channel.position]))
        assert [(s.frequency, s.amplitude) for s in found] == [
            (pytest.approx(lv["frequency_Hz"], rel=2e-3), pytest.approx(lv["amplitude"], rel=5e-3))
            for lv in series["levels"]
        ], key
        assert found[-1].stop / 1000.0 <= random["start_s"]


def test_the_lab_record_is_longer_by_default_than_the_others():
    """80 s: the series, then 53.4 s of random drive; 60 s for a random, sine or vehicle-derived record, 70 s for
    the damper's."""
    assert resolve_duration("bushing", RigOptions()) == SCHEDULE_DURATION["bushing", "lab"] == 80.0
    for excitation in ("random", "sine", "vehicle"):
        assert resolve_duration("bushing", RigOptions(excitation=excitation)) == 60.0
    assert resolve_duration("damper", RigOptions()) == 70.0
    assert resolve_duration("bushing", RigOptions(duration=40.0)) == 40.0


def test_a_lab_record_too_short_for_the_stiffness_series_is_refused_naming_the_lengths():
    with pytest.raises(SettingsError, match=r"'lab' excitation of 20 s: .*series takes 26.601 s.*at least 27.601 s"):
        simulate_rig("bushing", RigOptions(duration=20.0))


def test_random_excitation_stays_inside_the_lab_envelope():
    lab = simulate_rig("bushing", RigOptions(duration=40.0, noise=0.0)).measurement
    held_out = simulate_rig("bushing", RigOptions(duration=40.0, noise=0.0, excitation="random")).measurement
    for channel in BUSHING_CHANNELS.values():
        assert np.max(np.abs(held_out[channel.position])) < np.max(np.abs(lab[channel.position]))


def test_channels_units_and_effects():
    run = simulate_rig("bushing", RigOptions(duration=2.0, excitation="random"))
    m = run.measurement
    assert m.names == [
        "axial_displacement",
        "axial_velocity",
        "axial_force",
        "radial_displacement",
        "radial_velocity",
        "radial_force",
        "axial_rotation",
        "axial_angular_velocity",
        "axial_torque",
        "conical_rotation",
        "conical_angular_velocity",
        "conical_torque",
    ]
    assert m.units["axial_torque"] == "N.m" and m.units["conical_angular_velocity"] == "rad/s"
    assert run.truth["effects"] == ["viscoelastic", "friction"]
    assert run.truth["parameters"]["radial"]["stiffness"]["unit"] == "N/m"
    assert run.truth["parameters"]["conical_rotation"]["cubic_stiffness"]["unit"] == "N.m/rad^3"
    with pytest.raises(ValueError, match=r"'hysteresis'.*viscoelastic, friction"):
        simulate_rig("bushing", RigOptions(effects=("hysteresis",)))


def test_sine_series_measures_dynamic_stiffness_levels():
    run = simulate_rig("bushing", RigOptions(duration=30.0, excitation="sine", noise=0.0))
    levels = run.truth["excitation"]["drives"]["radial"]["levels"]
    assert {lv["frequency_Hz"] for lv in levels} == {1.0, 2.0, 5.0, 10.0, 15.0, 20.0}
    assert max(lv["amplitude"] for lv in levels) == pytest.approx(1.2e-3)


def test_same_seed_same_data_other_seed_other_data():
    options = RigOptions(duration=2.0, excitation="random")
    first, again = simulate_rig("bushing", options), simulate_rig("bushing", options)
    other = simulate_rig("bushing", replace(options, seed=7))
    for name in first.measurement.names:
        np.testing.assert_array_equal(first.measurement[name], again.measurement[name])
        assert not np.allclose(first.measurement[name], other.measurement[name])


def test_write_rig_puts_the_truth_beside_the_data(tmp_path):
    from nnfmu.data import load_measurement

    options = RigOptions(duration=2.0, seed=3, excitation="random")
    data, truth_file = write_rig("bushing", tmp_path / "rig.mf4", options)
    assert truth_file == tmp_path / "rig.truth.json"
    run = simulate_rig("bushing", options)
    assert json.loads(truth_file.read_text()) == run.truth
    loaded = load_measurement(data)
    for name in run.measurement.names:
        np.testing.assert_allclose(loaded[name], run.measurement[name], rtol=1e-9, atol=1e-12)
