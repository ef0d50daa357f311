"""The damper seal's pre-sliding stiffness (`presliding`, off by default): a Jenkins element, stepped exactly by the
rig's simulation and cross-checked against its own rate law integrated finely; stiff after each reversal, sliding at
the Coulomb level."""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.errors import SettingsError
from nnfmu.physics import DEFAULT_EFFECTS, DamperParams, DamperTruth

EFFECTS = ("seal_friction", "presliding")


def sine(dt: float, amplitude: float = 2e-3, frequency: float = 2.0, seconds: float = 1.0):
    t = np.arange(int(seconds / dt)) * dt
    w = 2 * np.pi * frequency
    return amplitude * np.sin(w * t), amplitude * w * np.cos(w * t), -amplitude * w * w * np.sin(w * t)


def test_presliding_is_off_by_default_and_needs_the_seal():
    assert "presliding" not in DEFAULT_EFFECTS["damper"]
    assert DamperTruth().state_names == ("valve_force",)
    with pytest.raises(SettingsError, match="switch on 'seal_friction'"):
        DamperTruth(DamperParams(), ("presliding",))


def test_the_seal_is_stiff_after_a_reversal_then_slides_at_the_coulomb_level():
    p = DamperParams()
    x, v, a = sine(1e-4)
    truth = DamperTruth(p, EFFECTS)
    force, states = truth.simulate(1e-4, x, v, a)
    seal = states[:, truth.state_names.index("seal_force")]
    np.testing.assert_allclose(force, truth.characteristic(v) + seal, atol=1e-9)  # the seal replaces the tanh
    assert np.max(np.abs(seal)) == pytest.approx(p.seal_friction)
    top = int(np.argmax(x))  # a reversal: down to the next one the seal unloads at the pre-sliding stiffness
    down = slice(top, top + int(np.argmin(x[top:])))
    travel = x[top] - x[down]
    stuck = travel < 0.9 * 2 * p.seal_friction / p.presliding_stiffness
    np.testing.assert_allclose(seal[down][stuck], p.seal_friction - p.presliding_stiffness * travel[stuck], atol=1e-6)
    sliding = travel > 2 * p.seal_friction / p.presliding_stiffness
    assert np.any(stuck) and np.any(sliding) and np.allclose(seal[down][sliding], -p.seal_friction)


@pytest.mark.slow
def test_the_exact_steps_match_the_rate_law_integrated_finely():
    truth = DamperTruth(DamperParams(), EFFECTS)
    # one period of the 2 Hz sine: a start from rest and both reversals (stuck, then sliding each way); the fine
    # Euler steps are a Python loop, 1 s of them took 28 s of the suite
    x, v, a = sine(1e-4, seconds=0.5)
    _, states = truth.simulate(1e-4, x, v, a)
    fine = 1e-6
    xf, vf, _ = sine(fine, seconds=0.5)
    seal, trace = 0.0, []
    for k, rate in enumerate(vf):
        if k % 100 == 0:
            trace.append(seal)
        seal += fine * truth.derivatives(k * fine, np.array([seal]), xf[k], rate)[0]
    np.testing.assert_allclose(states[:, 0], trace[: len(states)], atol=0.5)  # N, of a 50 N seal
