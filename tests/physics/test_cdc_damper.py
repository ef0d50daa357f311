"""CDC damper truth: the valve current blends the soft and hard curves monotonically, through the spool's lag."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nnfmu.errors import SettingsError
from nnfmu.physics import CDC_CURRENT_RANGE, CDCDamperParams, CDCDamperTruth

SPEEDS = np.array([-1.5, -0.6, -0.2, -0.05, 0.05, 0.2, 0.6, 1.5])


def steady_force(truth: CDCDamperTruth, current: float) -> np.ndarray:
    """Valve force at SPEEDS after the spool has settled at `current` [A]."""
    n = 200
    h = truth.hardness(1e-3, np.full(n, current))
    return truth.force(np.zeros(len(SPEEDS)), SPEEDS, np.zeros(len(SPEEDS)), np.full(len(SPEEDS), h[-1]))


def test_force_lies_between_the_soft_and_hard_curves_and_rises_with_current():
    p = CDCDamperParams()
    truth = CDCDamperTruth(p, ("valve_lag",))
    soft = truth.curve(SPEEDS, p.soft_rebound, p.soft_jounce)
    hard = truth.curve(SPEEDS, p.hard_rebound, p.hard_jounce)
    assert np.all(np.abs(hard) > 2 * np.abs(soft))
    previous = None
    for current in np.linspace(*CDC_CURRENT_RANGE, 7):
        force = steady_force(truth, current)
        assert np.all(np.abs(force) >= np.abs(soft) - 1e-9) and np.all(np.abs(force) <= np.abs(hard) + 1e-9)
        if previous is not None:
            assert np.all(np.abs(force) > np.abs(previous))
        previous = force
    np.testing.assert_allclose(steady_force(truth, 0.0), soft, rtol=1e-12)  # below the range: the soft end
    np.testing.assert_allclose(steady_force(truth, 2.0), hard, rtol=1e-12)  # above it: the hard end


@pytest.mark.parametrize("valve_time", [0.006, 0.015])
def test_a_current_step_opens_the_valve_with_its_time_constant(valve_time):
    truth = CDCDamperTruth(CDCDamperParams(valve_time=valve_time), ("valve_lag",))
    dt = 1e-4
    n = int(0.2 / dt)
    current = np.where(np.arange(n) >= 100, CDC_CURRENT_RANGE[1], CDC_CURRENT_RANGE[0])
    v = np.full(n, 0.5)
    force, states = truth.simulate(dt, np.zeros(n), v, np.zeros(n), current)
    reached = (force[100:] - force[99]) / (force[-1] - force[99])
    assert np.argmax(reached >= 1 - math.exp(-1)) * dt == pytest.approx(valve_time, rel=0.05)
    no_lag, _ = CDCDamperTruth(truth.params, ()).simulate(dt, np.zeros(n), v, np.zeros(n), current)
    assert no_lag[100] == pytest.approx(force[-1], rel=1e-4)  # without the lag at once


def test_gas_seal_and_inertia_add_their_terms():
    p = CDCDamperParams()
    rng = np.random.default_rng(3)
    x, v, a, i = rng.normal(0, 0.01, 50), rng.normal(0, 0.3, 50), rng.normal(0, 20, 50), rng.uniform(0.3, 1.8, 50)
    base, _ = CDCDamperTruth(p, ()).simulate(1e-3, x, v, a, i)
    full, _ = CDCDamperTruth(p, ("gas_force", "seal_friction", "inertia")).simulate(1e-3, x, v, a, i)
    gas = -(p.gas_preload - p.gas_rate * x)
    expected = gas + p.seal_friction * np.tanh(v / p.friction_velocity) + p.moving_mass * a
    np.testing.assert_allclose(full - base, expected, atol=1e-9)


def test_bad_parameters_and_effects_are_refused():
    with pytest.raises(SettingsError, match="current_hard > current_soft"):
        CDCDamperParams(current_soft=1.0, current_hard=0.5)
    with pytest.raises(SettingsError, match="unknown CDC damper effect"):
        CDCDamperTruth(CDCDamperParams(), ("hysteresis",))
