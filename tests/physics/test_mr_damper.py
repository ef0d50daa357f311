"""MR damper truth (Spencer's modified Bouc–Wen model): the qualitative behaviour an MR damper shows on a dyno, and its
integration against an independent stiff ODE solver."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nnfmu.errors import SettingsError
from nnfmu.physics import MRDamperParams, MRDamperTruth

DT = 0.5e-3  # the dyno's internal step


def sine(amplitude: float, frequency: float, cycles: float, dt: float = DT):
    t = np.arange(int(round(cycles / frequency / dt)) + 1) * dt
    w = 2 * math.pi * frequency
    return t, amplitude * np.sin(w * t), amplitude * w * np.cos(w * t), -amplitude * w * w * np.sin(w * t)


def last_cycle(t: np.ndarray, frequency: float, cycles: int) -> np.ndarray:
    return t >= (cycles - 1) / frequency - 1e-9


def test_force_rises_with_voltage_at_the_same_velocity():
    truth = MRDamperTruth(MRDamperParams(), ())
    t, x, v, a = sine(0.02, 3.0, 3)
    peaks = []
    for volts in (0.0, 1.0, 2.5, 5.0):
        force, _ = truth.simulate(DT, x, v, a, np.full(len(t), volts))
        peaks.append(force[last_cycle(t, 3.0, 3)].max())
    assert np.all(np.diff(peaks) > 0)
    assert 1000 < peaks[-1] < 5000 and peaks[-1] > 3 * peaks[0]  # a few kN, a wide controllable range


def test_hysteresis_loop_area_grows_with_voltage():
    truth = MRDamperTruth(MRDamperParams(), ())
    t, x, v, a = sine(0.02, 2.0, 3)
    window = last_cycle(t, 2.0, 3)
    energies = []
    for volts in (0.0, 2.0, 4.0):
        force, _ = truth.simulate(DT, x, v, a, np.full(len(t), volts))
        energies.append(np.trapezoid(force[window] * v[window], t[window]))  # dissipated per cycle [J]
    assert energies[0] > 0 and np.all(np.diff(energies) > 0.2 * energies[0])


@pytest.mark.parametrize("eta", [190.0, 80.0])
def test_a_voltage_step_changes_the_force_with_time_constant_one_over_eta(eta):
    truth = MRDamperTruth(replace(MRDamperParams(), eta=eta), ("command_lag",))
    dt = 0.05e-3
    t = np.arange(int(0.16 / dt)) * dt
    step_at = int(0.05 / dt)
    x, v, a = 0.3 * t - 0.02, np.full(len(t), 0.3), np.zeros(len(t))
    command = np.where(np.arange(len(t)) >= step_at, 5.0, 0.0)
    force, states = truth.simulate(dt, x, v, a, command)
    before, settled = force[step_at - 1], force[step_at + int(8 / eta / dt)]
    reached = (force[step_at:] - before) / (settled - before)
    crossing = np.argmax(reached >= 1 - math.exp(-1)) * dt
    assert crossing == pytest.approx(1 / eta, rel=0.1)
    no_lag, _ = MRDamperTruth(truth.params, ()).simulate(dt, x, v, a, command)
    assert (no_lag[step_at + 2] - before) / (settled - before) > 0.9  # without the lag the force follows at once
    assert states[step_at + int(1 / eta / dt), 0] == pytest.approx(5 * (1 - math.exp(-1)), rel=0.01)


def _reference(params: MRDamperParams, t: np.ndarray, x: np.ndarray, v: np.ndarray, volts: float) -> np.ndarray:
    """The same equations integrated by scipy's Radau (stiff, adaptive) on an analytic sine, as written in Spencer's
    paper: states y and z, no closed forms."""
    w = 2 * math.pi * 2.0
    alpha, c0, c1 = params.alpha(volts), params.c0(volts), params.c1(volts)

    def rhs(time, s):
        y, z = s
        xt, vt = 0.02 * math.sin(w * time), 0.02 * w * math.cos(w * time)
        ydot = (alpha * z + c0 * vt + params.k0 * (xt - y)) / (c0 + c1)
        r = vt - ydot
        zdot = -params.gamma * abs(r) * z * abs(z) - params.beta * r * z * z + params.a_bw * r
        return [ydot, zdot]

    solution = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0], method="Radau", t_eval=t, rtol=1e-8, atol=1e-11, max_step=1e-3)
    y, z = solution.y
    ydot = (alpha * z + c0 * v + params.k0 * (x - y)) / (c0 + c1)
    return c1 * ydot


@pytest.mark.parametrize("volts", [0.0, 3.0])
def test_integration_matches_a_stiff_adaptive_solver_at_the_dyno_step(volts):
    params = MRDamperParams()
    t, x, v, a = sine(0.02, 2.0, 1.5)
    force, _ = MRDamperTruth(params, ()).simulate(DT, x, v, a, np.full(len(t), volts))
    reference = _reference(params, t, x, v, volts)
    error = np.sqrt(np.mean((force - reference) ** 2)) / np.sqrt(np.mean(reference**2))
    assert error < 0.01


def test_gas_and_inertia_add_their_terms():
    params = MRDamperParams()
    t, x, v, a = sine(0.02, 4.0, 1)
    command = np.full(len(t), 2.0)
    base, _ = MRDamperTruth(params, ()).simulate(DT, x, v, a, command)
    full, _ = MRDamperTruth(params, ("gas_force", "inertia")).simulate(DT, x, v, a, command)
    np.testing.assert_allclose(full - base, params.k1 * (x - params.x0) + params.moving_mass * a, atol=1e-9)


def test_bad_parameters_and_effects_are_refused():
    with pytest.raises(SettingsError, match="eta"):
        MRDamperParams(eta=0.0)
    with pytest.raises(SettingsError, match="unknown MR damper effect"):
        MRDamperTruth(MRDamperParams(), ("temperature",))
