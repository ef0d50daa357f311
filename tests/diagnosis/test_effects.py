"""The effect library: stable names, the channels each family needs, and regressors checked against analytic
signals (a sine stroke), plus the out-of-sample ranking test on its own."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from nnfmu.data import Measurement
from nnfmu.diagnosis import EFFECTS, DiagnosisError, DiagnosisSettings, diagnose, select_effects
from nnfmu.diagnosis.ranking import fold_mask, gain_test
from nnfmu.diagnosis.signals import build_signals

RATE = 1000.0
AMPLITUDE = 0.02  # m
FREQUENCY = 2.0  # Hz
DAMPING = 3000.0  # N.s/m


def sine_measurement(channels: tuple[str, ...] = ("displacement", "velocity"), seconds: float = 4.0) -> Measurement:
    """A 2 Hz, ±20 mm sine stroke with a linear damper force (no noise)."""
    t = np.arange(int(seconds * RATE)) / RATE
    w = 2 * np.pi * FREQUENCY
    signals = {
        "displacement": AMPLITUDE * np.sin(w * t),
        "velocity": AMPLITUDE * w * np.cos(w * t),
        "temperature": 300.0 + 0.5 * t,
    }
    units = {"displacement": "m", "velocity": "m/s", "temperature": "K", "force": "N"}
    chosen = {name: signals[name] for name in channels}
    chosen["force"] = DAMPING * signals["velocity"]
    return Measurement(t, chosen, {k: units[k] for k in chosen}, "sine")


def regressors(name: str, m: Measurement, inputs=("velocity",)):
    signals = build_signals(m, m["force"], "force", inputs)
    return EFFECTS[name].regressors(signals, DiagnosisSettings())


def test_the_library_has_the_stable_names():
    assert list(EFFECTS) == [
        "seal_friction",
        "gas_force",
        "hysteresis",
        "backlash",
        "presliding_friction",
        "inertia",
        "temperature",
        "frequency_dependence",
        "amplitude_dependence",
        "sensor_offset",
    ]
    for effect in EFFECTS.values():
        assert effect.description and isinstance(effect.requires, tuple)


@pytest.mark.parametrize("name", list(EFFECTS))
def test_every_family_gives_finite_named_columns(name):
    m = sine_measurement(("displacement", "velocity", "temperature"))
    r = regressors(name, m)
    assert r.matrix.shape == (len(m), len(r.names))
    assert np.all(np.isfinite(r.matrix))
    assert r.note


def test_seal_friction_is_the_smoothed_sign_of_velocity():
    m = sine_measurement()
    r = regressors("seal_friction", m)
    sharpest = r.matrix[:, 0]
    v = m["velocity"]
    fast = np.abs(v) > 0.1 * np.max(np.abs(v))
    assert np.allclose(sharpest[fast], np.sign(v[fast]), atol=1e-6)


def test_inertia_derives_acceleration_when_the_rig_did_not_measure_it():
    m = sine_measurement()
    r = regressors("inertia", m)
    w = 2 * np.pi * FREQUENCY
    analytic = -AMPLITUDE * w**2 * np.sin(w * m.time)
    assert np.max(np.abs(r.matrix[:, 0] - analytic)) < 1e-3 * AMPLITUDE * w**2
    assert "derived" in r.note and "Savitzky-Golay" in r.note


def test_temperature_uses_the_channel_or_else_dissipated_energy():
    with_channel = regressors("temperature", sine_measurement(("displacement", "velocity", "temperature")))
    assert with_channel.missing == ()
    # 0.5 K/s rise, centred on its mean
    t = np.arange(4000) / RATE
    assert np.allclose(with_channel.matrix[:, 0], 0.5 * (t - t.mean()), atol=1e-9)

    without = regressors("temperature", sine_measurement())
    assert without.missing == ("temperature",)
    assert "dissipated energy" in without.note and "temperature [K]" in without.note
    # energy of a linear damper over whole cycles: c·(Aω)²/2 per second
    energy = without.matrix[:, 0]
    w = 2 * np.pi * FREQUENCY
    rate = DAMPING * (AMPLITUDE * w) ** 2 / 2  # W
    assert (energy[-1] - energy[0]) == pytest.approx(rate * (t[-1] - t[0]), rel=2e-3)


def test_frequency_dependence_states_vanish_for_a_constant_stroke():
    m = sine_measurement()
    m.channels["displacement"] = np.full(len(m), 0.01)
    assert np.allclose(regressors("frequency_dependence", m).matrix, 0.0)


def test_hysteresis_memory_is_one_at_a_reversal_and_fades_over_the_stroke():
    m = sine_measurement()
    r = regressors("hysteresis", m)
    memory = r.matrix[:, [i for i, n in enumerate(r.names) if n.startswith("sign(velocity)")][0]]  # shortest length
    v = m["velocity"]
    reversals = np.nonzero(np.diff(np.sign(v)))[0][1:]  # skip the start
    after = reversals + 3  # just past the reversal threshold
    assert np.allclose(np.abs(memory[after]), 1.0, atol=0.05)
    assert np.all(np.sign(memory[after]) == np.sign(v[after]))
    mid_stroke = np.abs(v) > 0.99 * np.max(np.abs(v))
    assert np.max(np.abs(memory[mid_stroke])) < 1e-3


def test_a_family_without_its_channel_is_reported_untestable():
    m = sine_measurement(("velocity",))
    predicted = m["force"] + np.random.default_rng(0).standard_normal(len(m))
    d = diagnose(m, predicted, "force", ["velocity"], DiagnosisSettings())
    untestable = {e.name: e for e in d.ranking if not e.testable}
    # both readings of the stop operators need the displacement (so does telling them apart)
    assert set(untestable) == {
        "gas_force",
        "backlash",
        "presliding_friction",
        "frequency_dependence",
        "amplitude_dependence",
    }
    assert untestable["gas_force"].missing_channels == ("displacement",)
    assert any("gas_force could not be tested" in note for note in d.missing_measurements)


def test_a_residual_without_variation_is_refused():
    m = sine_measurement()
    with pytest.raises(DiagnosisError, match="residual of 'force' is constant"):
        diagnose(m, m["force"] - 2.0, "force", ["velocity"], DiagnosisSettings())


def test_unknown_effect_names_are_refused():
    with pytest.raises(DiagnosisError, match="unknown effect.*'viscosity'.*seal_friction"):
        select_effects(("seal_friction", "viscosity"))


def test_out_of_sample_gain_ignores_a_regressor_unrelated_to_the_residual():
    rng = np.random.default_rng(0)
    n = 4000
    residual = rng.standard_normal(n)
    fold = fold_mask(n, 32)
    assert fold.sum() == n // 2
    unrelated = rng.standard_normal((n, 3))
    base = np.zeros((n, 0))
    null = gain_test(residual, base, unrelated, fold)
    assert null.explained < 0.005 and null.p_value > 0.01
    related = gain_test(residual + 0.5 * unrelated[:, 0], base, unrelated, fold)
    assert related.explained == pytest.approx(0.25 / 1.25, abs=0.03) and related.p_value < 1e-10


def test_the_test_discounts_autocorrelated_evidence():
    """A slow drift against a slowly wandering residual: a naive test would call it significant; the effective
    sample size and the p-value say how little independent evidence there is."""
    rng = np.random.default_rng(1)
    n = 20000
    wander = np.cumsum(rng.standard_normal(n))
    wander -= np.linspace(wander[0], wander[-1], n)  # a bridge: no net trend
    drift = np.column_stack([np.ones(n), np.linspace(0, 1, n)])
    test = gain_test(wander, np.zeros((n, 0)), drift, fold_mask(n, 32))
    assert test.effective_samples < n / 50
    assert test.p_value > 0.001
    # the naive in-sample F-test on the same data claims overwhelming significance
    coefficients, *_ = np.linalg.lstsq(drift, wander, rcond=None)
    sse_full, sse_none = np.sum((wander - drift @ coefficients) ** 2), np.sum(wander**2)
    f = ((sse_none - sse_full) / 2) / (sse_full / (n - 2))
    assert stats.f.sf(f, 2, n - 2) < 1e-6
