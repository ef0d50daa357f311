"""Lab excitations: exact rates of sines and random signals, PSD against the target shape, series scheduling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import welch

from nnfmu.data.rigs import DamperDyno, SineLevel, SpectrumShape
from nnfmu.data.rigs.excitation import random_motion, sine_level, sine_series, sine_series_cycles

RATE = 4000.0


def assert_consistent_rates(motion, rate: float, rel: float) -> None:
    """The stated rate and acceleration equal numerical derivatives of the position (interior samples)."""
    v = np.gradient(motion.x, 1 / rate)
    a = np.gradient(motion.v, 1 / rate)
    inner = slice(2, -2)
    assert np.max(np.abs(v[inner] - motion.v[inner])) < rel * np.max(np.abs(motion.v))
    assert np.max(np.abs(a[inner] - motion.a[inner])) < rel * np.max(np.abs(motion.a))


def test_sine_level_ramps_from_rest_and_reaches_its_peak_rate():
    level = SineLevel(amplitude=0.025, frequency=5.0)
    motion = sine_level(level, cycles=4, rate=RATE)
    assert len(motion) == int(4 / 5.0 * RATE)
    assert abs(motion.x[0]) < 1e-12 and abs(motion.v[0]) < 1e-12
    assert np.max(np.abs(motion.v)) == pytest.approx(2 * math.pi * 5.0 * 0.025, rel=1e-3)
    assert_consistent_rates(motion, RATE, rel=5e-3)  # central differences err most where the ramp joins


def test_random_motion_rates_are_its_derivatives():
    shape = SpectrumShape(f_low=1.0, f_corner=2.0, f_high=30.0, slope=2.0)
    motion = random_motion(shape, RATE, int(5 * RATE), np.random.default_rng(0), fade=0.5)
    assert motion.x[0] == 0 and motion.v[0] == 0
    assert_consistent_rates(motion, RATE, rel=5e-3)


def test_random_motion_psd_follows_the_target_shape():
    shape = SpectrumShape(f_low=0.5, f_corner=3.0, f_high=40.0, slope=2.0)
    rate = 1000.0
    motion = random_motion(shape, rate, int(60 * rate), np.random.default_rng(5), fade=0.5)
    f, psd = welch(motion.x, fs=rate, nperseg=4096)
    bands = np.geomspace(1.0, 35.0, 16)
    error_db = []
    for lo, hi in zip(bands[:-1], bands[1:]):
        inside = (f >= lo) & (f < hi)
        error_db.append(10 * np.log10(np.mean(psd[inside]) / np.mean(shape.psd(f[inside]))))
    error_db = np.array(error_db) - np.median(error_db)
    assert np.max(np.abs(error_db)) < 1.5  # worst seen over 20 seeds: 1.04 dB
    # the target's slope: 40 dB per decade above the corner
    high = (f > 5.0) & (f < 30.0)
    slope = np.polyfit(np.log10(f[high]), 10 * np.log10(psd[high]), 1)[0]
    assert slope == pytest.approx(-10 * shape.slope, abs=1.0)
    assert np.sum(psd[f > 50.0]) < 1e-6 * np.sum(psd)


def test_random_motion_depends_on_the_generator_only():
    shape = SpectrumShape(1.0, 1.0, 20.0, 2.0)
    one = random_motion(shape, 1000.0, 3000, np.random.default_rng(1), fade=0.5)
    same = random_motion(shape, 1000.0, 3000, np.random.default_rng(1), fade=0.5)
    other = random_motion(shape, 1000.0, 3000, np.random.default_rng(2), fade=0.5)
    np.testing.assert_array_equal(one.x, same.x)
    assert not np.allclose(one.x, other.x)


def test_sine_series_fits_the_budget_or_says_what_it_needs():
    levels = [SineLevel(0.01, 1.0), SineLevel(0.02, 4.0)]
    cycles = sine_series_cycles(levels, budget=10.0, rest=0.25)
    assert cycles == 7  # (10 - 0.5) / 1.25 = 7.6
    motion, described = sine_series(levels, cycles, rate=1000.0, rest=0.25)
    assert len(motion) == int(round((7 / 1.0 + 0.25 + 7 / 4.0 + 0.25) * 1000))
    assert described[1]["start_s"] == pytest.approx(7.25)
    with pytest.raises(ValueError, match="needs at least 4.25 s"):
        sine_series_cycles(levels, budget=3.0, rest=0.25)


def test_damper_dyno_levels_have_the_standard_peak_velocities_within_the_stroke():
    dyno = DamperDyno()
    levels = dyno.sine_levels()
    peaks = [2 * math.pi * lv.amplitude * lv.frequency for lv in levels]
    assert peaks == pytest.approx(list(dyno.peak_velocities))
    assert all(lv.amplitude <= dyno.max_amplitude + 1e-12 for lv in levels)
    assert all(lv.frequency >= dyno.min_frequency - 1e-12 for lv in levels)


def test_damper_random_reaches_the_peak_velocity_or_the_stroke_limit():
    dyno = DamperDyno()
    motion, described = dyno.random(1000.0, 30000, np.random.default_rng(0))
    peak_v, peak_x = np.max(np.abs(motion.v)), np.max(np.abs(motion.x))
    assert peak_v <= dyno.random_peak_velocity + 1e-9 and peak_x <= dyno.stroke_limit + 1e-12
    assert peak_v == pytest.approx(dyno.random_peak_velocity) or peak_x == pytest.approx(dyno.stroke_limit)
    assert described["peak_velocity_m/s"] == pytest.approx(peak_v)
