"""The backlash effect's two halves: its regressors (stop operators of displacement at gaps sized by the travel
between reversals) against the Stop feature of the step graph, and its extension. (On the measured BRFD damper:
tests/workflows/loop/test_brfd_loop.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.data import Measurement
from nnfmu.diagnosis import EFFECTS, DiagnosisSettings, Extension, NoExtension
from nnfmu.diagnosis.effects.shared import backlash_radii, stop_operator
from nnfmu.diagnosis.signals import build_signals
from nnfmu.models.features import FeatureSpec, Stop, Tap


def triangle(period: float = 1.0, amplitude: float = 0.02, dt: float = 0.001, cycles: int = 4) -> Measurement:
    """A triangle-wave displacement [m] and its velocity [m/s]; force 0 (only the channels matter here)."""
    t = np.arange(int(cycles * period / dt)) * dt
    phase = (t / period) % 1.0
    x = amplitude * (4 * np.abs(phase - 0.5) - 1)
    v = np.gradient(x, dt)
    return Measurement(
        t,
        {"displacement": x, "velocity": v, "force": np.zeros_like(t)},
        {"displacement": "m", "velocity": "m/s", "force": "N"},
        "triangle",
    )


def test_the_backlash_regressors_are_the_feature_kinds_stop_operators():
    """The diagnosis's stop operator (effects/shared.py) and the step graph's (Stop feature) are written
    independently; once the first reversal has closed the gap they agree to rounding, and both stay within
    ±radius."""
    m = triangle()
    for radius in (0.001, 0.005):
        diagnosis = stop_operator(m["displacement"], radius)
        feature = FeatureSpec((), "force", (Stop("displacement", radius=radius),)).features(m.channels, 0.001)[:, 0]
        settled = m.time > 0.75  # the first reversal is at 0.5 s; the gap closes 2·radius of travel later
        np.testing.assert_allclose(diagnosis[settled], feature[settled], rtol=0, atol=1e-15)
        assert np.max(np.abs(diagnosis)) == pytest.approx(radius)


def test_the_gap_sizes_follow_the_travel_between_reversals():
    m = triangle(amplitude=0.02)  # travel between reversals 0.04 m
    radii = backlash_radii(m["velocity"], 0.001, (0.1, 0.5))
    assert radii == pytest.approx((0.002, 0.01), rel=0.02)
    signals = build_signals(m, m["force"] + 1.0, "force", ("velocity",))
    regressors = EFFECTS["backlash"].regressors(signals, DiagnosisSettings(reversal_fractions=(0.1, 0.5)))
    assert regressors.matrix.shape == (len(m), 2) and regressors.names[0].startswith("stop(displacement, radius=0.002")


def test_the_backlash_extension_adds_stop_states_of_displacement_and_needs_displacement():
    m = triangle(amplitude=0.02)
    spec = FeatureSpec((Tap("velocity"),), "force")
    settings = DiagnosisSettings(reversal_fractions=(0.1, 0.5))
    ext = EFFECTS["backlash"].extension(spec, m, np.arange(len(m)), settings)
    assert isinstance(ext, Extension)
    assert all(name.startswith("stop(displacement, radius=") for name in ext.added) and len(ext.added) == 2
    assert [d.radius for d in ext.spec.derived] == pytest.approx([0.002, 0.01], rel=0.02)
    assert ext.spec.channels == ["velocity", "displacement"] and ext.spec.state_size == 2
    without = Measurement(m.time, {"velocity": m["velocity"], "force": m["force"]}, {"velocity": "m/s", "force": "N"})
    missing = EFFECTS["backlash"].extension(spec, without, np.arange(len(m)), settings)
    assert isinstance(missing, NoExtension) and missing.missing_channels == ("displacement",)
