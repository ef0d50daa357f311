"""Savitzky-Golay rates against analytic derivatives and against finite differences on noisy data."""

import numpy as np
import pytest

from nnfmu.data import DataError, Measurement, derive_rates
from nnfmu.data.derive import derivative, window_length

AMPLITUDE = 0.01  # m


def _sine(frequency: float, rate: float, seconds: float = 2.0):
    t = np.arange(int(seconds * rate)) / rate
    w = 2 * np.pi * frequency
    x = AMPLITUDE * np.sin(w * t)
    v = AMPLITUDE * w * np.cos(w * t)
    a = -AMPLITUDE * w**2 * np.sin(w * t)
    return t, x, v, a, w


def test_window_spans_about_five_milliseconds_and_at_least_seven_samples():
    assert window_length(1e-3) == 7
    assert window_length(1 / 2000) == 11
    assert window_length(1e-4) == 51
    assert window_length(1e-2) == 7


def test_derivatives_of_a_slow_sine_are_nearly_exact_including_the_ends():
    t, x, v, a, w = _sine(5.0, 1000.0)
    dt = t[1] - t[0]
    assert np.max(np.abs(derivative(x, dt, 1) - v)) < 1e-5 * AMPLITUDE * w
    assert np.max(np.abs(derivative(x, dt, 2) - a)) < 1e-3 * AMPLITUDE * w**2


def test_gain_error_below_a_tenth_of_a_percent_at_40_hz():
    t, x, v, a, w = _sine(40.0, 1000.0)
    dt = t[1] - t[0]
    inner = slice(window_length(dt), -window_length(dt))
    assert np.max(np.abs(derivative(x, dt, 1) - v)[inner]) < 1e-3 * AMPLITUDE * w
    assert np.max(np.abs(derivative(x, dt, 2) - a)[inner]) < 1e-3 * AMPLITUDE * w**2


def test_far_better_than_finite_differences_on_noisy_data():
    t, x, v, a, w = _sine(5.0, 5000.0)
    dt = t[1] - t[0]
    noisy = x + np.random.default_rng(1).normal(0.0, 1e-3 * AMPLITUDE, x.size)
    midpoints = t[:-1] + dt / 2

    def rms(error):
        return float(np.sqrt(np.mean(error**2)))

    sg_v = rms(derivative(noisy, dt, 1) - v)
    diff_v = rms(np.diff(noisy) / dt - AMPLITUDE * w * np.cos(w * midpoints))
    sg_a = rms(derivative(noisy, dt, 2) - a)
    diff_a = rms(np.diff(noisy, 2) / dt**2 - a[1:-1])
    assert sg_v * 10 < diff_v
    assert sg_a * 30 < diff_a


def _measurement(channels, rate=1000.0, n=400):
    t = np.arange(n) / rate
    units = {"displacement": "m", "velocity": "m/s", "rotation": "rad", "force": "N"}
    return Measurement(
        time=t,
        channels={name: make(t) for name, make in channels.items()},
        units={name: next(u for base, u in units.items() if name.endswith(base)) for name in channels},
        source="memory-test",
    )


def test_prefixed_channels_get_prefixed_rates_with_notes():
    m = _measurement(
        {
            "axial_displacement": lambda t: 0.002 * t**2,
            "conical_rotation": lambda t: 0.5 * t,
            "axial_force": lambda t: 0 * t,
        }
    )
    derived = derive_rates(m)
    assert derived.units["axial_velocity"] == "m/s"
    assert derived.units["axial_acceleration"] == "m/s^2"
    assert derived.units["conical_angular_velocity"] == "rad/s"
    np.testing.assert_allclose(derived["axial_velocity"], 0.004 * m.time, atol=1e-12)
    np.testing.assert_allclose(derived["axial_acceleration"], 0.004, rtol=1e-9)
    np.testing.assert_allclose(derived["conical_angular_velocity"], 0.5, rtol=1e-9)
    assert "axial_displacement" in derived.notes["derived:axial_velocity"]
    assert "Savitzky-Golay" in derived.notes["derived:conical_angular_velocity"]
    assert "axial_velocity" not in m.channels and not m.notes


def test_measured_rates_are_kept_and_measured_velocity_gives_acceleration():
    m = _measurement({"displacement": lambda t: t**2, "velocity": lambda t: 3.0 * t})
    derived = derive_rates(m)
    assert derived["velocity"] is m["velocity"]
    np.testing.assert_allclose(derived["acceleration"], 3.0, rtol=1e-9)  # from velocity, not 2.0 from displacement
    assert "derived:velocity" not in derived.notes


def test_too_few_samples_to_derive_names_the_channels():
    m = _measurement({"displacement": lambda t: t}, n=4)
    with pytest.raises(DataError, match=r"memory-test: cannot derive 'velocity' from 'displacement': 4 samples"):
        derive_rates(m)
