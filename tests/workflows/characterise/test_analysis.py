"""The readings of a sine test on arrays (no FMU): first harmonic, dynamic stiffness against the closed form of a
linear spring-damper, the damper's forces at peak velocity, its gas force and friction against the truth law's
parameters, and the detection of sine tests in a lab schedule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nnfmu.data.rigs import DamperParams, DamperTruth
from nnfmu.data.rigs.excitation import MIN_SINE_CYCLES, Motion, SineLevel, SpectrumShape, random_motion, sine_series
from nnfmu.errors import SettingsError
from nnfmu.workflows.characterise.analysis import damper_point, first_harmonic, stiffness_point
from nnfmu.workflows.characterise.damper import damper_tests, read_damper
from nnfmu.workflows.characterise.detect import find_sine_tests
from nnfmu.workflows.characterise.plots import amplitude_groups
from nnfmu.workflows.characterise.settings import DamperTestSettings
from nnfmu.workflows.characterise.signals import SineTest, check_tests, sine_motion
from nnfmu.workflows.characterise.truth import damper_truth_runs

T = 1e-3


@pytest.mark.parametrize("frequency", [1.0, 7.3, 100.0])
def test_a_linear_spring_damper_has_the_closed_form_dynamic_stiffness(frequency: float) -> None:
    """|K*| = sqrt(k² + (cω)²), loss angle atan(cω/k), read from one sampled cycle."""
    k, c = 1.0e6, 800.0
    motion = sine_motion(SineTest(1e-3, frequency, 2), T)
    m = motion.measured
    force = k * motion.position + c * motion.rate
    point = stiffness_point("axial", motion.time[m], motion.position[m], force[m], frequency)
    omega = 2 * math.pi * frequency
    assert point.dynamic_stiffness == pytest.approx(math.hypot(k, c * omega), rel=1e-9)
    assert point.loss_angle == pytest.approx(math.degrees(math.atan(c * omega / k)), abs=1e-7)
    assert point.amplitude == pytest.approx(1e-3, rel=1e-9)


def test_the_first_harmonic_ignores_the_mean_and_the_third_harmonic() -> None:
    t = np.arange(1001) * T
    y = 3.0 + 2.0 * np.sin(2 * np.pi * t + 0.4) + 0.5 * np.sin(6 * np.pi * t)
    fit = first_harmonic(t, y, 1.0)
    assert fit.mean == pytest.approx(3.0, abs=1e-3)
    assert fit.phasor == pytest.approx(2.0 * complex(math.cos(0.4), math.sin(0.4)), abs=2e-3)


def test_the_forces_at_peak_velocity_of_a_shifted_sine() -> None:
    """Rebound and jounce force are read where the velocity peaks, whatever the sine's phase in the window."""
    t = np.arange(3000) * T
    x = 0.02 * np.sin(2 * np.pi * 1.5 * t + 1.1)
    v = 0.02 * 2 * np.pi * 1.5 * np.cos(2 * np.pi * 1.5 * t + 1.1)
    force = np.where(v > 0, 3000.0 * v, 1000.0 * v) + 5000.0 * x  # a spring term is zero at peak velocity
    point = damper_point(t, x, force, 1.5)
    peak = 0.02 * 2 * np.pi * 1.5
    assert point.peak_velocity == pytest.approx(peak, rel=1e-9)
    assert point.rebound_force == pytest.approx(3000.0 * peak, rel=1e-4)
    assert point.jounce_force == pytest.approx(-1000.0 * peak, rel=1e-4)


def test_gas_force_and_friction_are_read_from_the_truth_law() -> None:
    """The truth damper with gas spring (250 N) and seal friction (50 N): the slowest test reads both within 2 N."""
    truth = DamperTruth(DamperParams(), ("hysteresis", "seal_friction", "gas_force"))
    settings = DamperTestSettings(peak_velocities=(0.05,), stroke=0.008, settle_cycles=1)
    found = read_damper(damper_truth_runs(truth, damper_tests(settings, [None]), T)).gas_friction[None]
    assert found.gas_force == pytest.approx(DamperParams().gas_preload, abs=2.0)
    assert found.friction == pytest.approx(DamperParams().seal_friction, abs=2.0)


def _schedule(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, list[SineLevel]]:
    """Two sine levels (ramped in and out, rests between) then a band-limited random drive, with sensor noise."""
    levels = [SineLevel(0.008, 1.0), SineLevel(0.025, 3.0)]
    sine, _ = sine_series(levels, 5, 1 / T, 0.2)
    shape = SpectrumShape(f_low=1.0, f_corner=1.0, f_high=20.0, slope=2.0)
    noise_free = Motion.concatenate([sine, random_motion(shape, 1 / T, 20000, rng, 0.5).scaled(0.01)])
    x = noise_free.x + 25e-6 * rng.normal(size=len(noise_free))
    return np.arange(len(x)) * T, x, levels


def test_sine_tests_are_found_in_a_lab_schedule_and_the_random_part_is_left_out() -> None:
    time, x, levels = _schedule(np.random.default_rng(3))
    found = find_sine_tests(time, x)
    assert [(s.frequency, s.amplitude) for s in found] == [
        (pytest.approx(lv.frequency, rel=1e-3), pytest.approx(lv.amplitude, rel=2e-3)) for lv in levels
    ]
    assert all(s.cycles >= 3 for s in found)
    assert find_sine_tests(time[12000:], x[12000:]) == []  # the random drive alone


@pytest.mark.parametrize("cycles", [MIN_SINE_CYCLES, 5])
def test_a_levels_whole_amplitude_cycles_are_found_between_its_ramps(cycles: int) -> None:
    """A level ramped in and out over half a cycle each holds cycles - 1 whole cycles at full amplitude, between its
    downward zero crossings: the fewest a rig records (3) gives 2, as many as a test needs; between upward crossings
    there would be 1."""
    levels = [SineLevel(0.008, 1.0), SineLevel(0.025, 3.0), SineLevel(0.025, 12.0)]
    sine, _ = sine_series(levels, cycles, 1 / T, 0.2)
    x = sine.x + 25e-6 * np.random.default_rng(4).normal(size=len(sine))
    found = find_sine_tests(np.arange(len(x)) * T, x)
    assert [(s.cycles, s.frequency, s.amplitude) for s in found] == [
        (cycles - 1, pytest.approx(lv.frequency, rel=1e-3), pytest.approx(lv.amplitude, rel=2e-3)) for lv in levels
    ]


@pytest.mark.parametrize("stroke", [0.025, 0.01, 0.0173])
def test_every_read_cycle_holds_both_peak_velocities(stroke: float) -> None:
    """Whatever fraction of a sample the period ends on, the read cycle starts after the ramp and holds both peaks."""
    settings = DamperTestSettings(stroke=stroke, settle_cycles=1)
    for test in damper_tests(settings, [None]):
        motion = sine_motion(test, T)
        m = motion.measured
        assert motion.time[m][0] >= test.settle_cycles / test.frequency - 1e-12
        force = np.where(motion.rate > 0, 2000.0 * motion.rate, 700.0 * motion.rate)
        point = damper_point(motion.time[m], motion.position[m], force[m], test.frequency)
        assert point.peak_velocity == pytest.approx(test.peak_rate, rel=1e-9)
        # the parabola through three samples: 2e-5 at most where a sample spans 0.15 rad (1.5 m/s on ±10 mm)
        assert point.rebound_force == pytest.approx(2000.0 * test.peak_rate, rel=3e-5)
        assert point.jounce_force == pytest.approx(-700.0 * test.peak_rate, rel=3e-5)


def test_tests_are_bounded_before_any_runs() -> None:
    with pytest.raises(SettingsError, match="100 Hz leaves 5 samples a cycle"):
        check_tests([SineTest(1e-3, 100.0, 1)], 0.002, "x.onnx")
    with pytest.raises(SettingsError, match="more than 20000000"):
        check_tests([SineTest(1e-3, 1e-4, 2)], 1e-3, "x.onnx")
    with pytest.raises(SettingsError, match="2001 test points"):
        check_tests([SineTest(1e-3, 10.0, 1)] * 2001, 1e-3, "x.onnx")
    with pytest.raises(SettingsError, match="peak velocities: -0.1 m/s"):
        DamperTestSettings(peak_velocities=(0.1, -0.1))


def test_a_records_amplitudes_group_by_their_nominal_level() -> None:
    assert amplitude_groups([1.2499e-3, 2.5e-3, 1.25003e-3, 2.4999e-3, 0.6e-3]) == [0, 1, 0, 1, 2]
