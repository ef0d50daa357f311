"""Diagnosis of residuals whose cause is known: a rig run with an effect the "model" (the same run without it)
lacks, pure sensor noise, coloured and nonlinear residuals, and the measured BRFD friction damper slice."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

from nnfmu.data import Measurement
from nnfmu.data.importers import load_brfd
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.diagnosis import DiagnosisError, DiagnosisSettings, FamilyGains, diagnose
from nnfmu.diagnosis.residual_tests import residual_tests, whiteness_test

MODEL_EFFECTS = ("hysteresis", "seal_friction", "inertia")  # the rig's default: what the "model" has
DURATION = 20.0  # s at 1 kHz
BRFD = Path(__file__).parents[1] / "data" / "brfd"


@cache
def rig_case(missing: tuple[str, ...], seed: int = 1) -> tuple[Measurement, np.ndarray]:
    """(measured run with every effect, with sensor noise; noise-free force of the same run without `missing`).

    Same seed, so the same motion: the residual is exactly the missing effects plus the force sensor's noise.
    """
    every = tuple(sorted(set(MODEL_EFFECTS) | set(missing)))
    model = tuple(e for e in every if e not in missing)
    options = RigOptions(duration=DURATION, seed=seed, effects=every, excitation="random")
    measured = simulate_rig("damper", options).measurement
    predicted = simulate_rig(
        "damper", RigOptions(duration=DURATION, seed=seed, effects=model, excitation="random", noise=0.0)
    ).measurement["force"]
    return measured, predicted


def run(missing: tuple[str, ...], drop: tuple[str, ...] = ()):
    measured, predicted = rig_case(missing)
    channels = {k: v for k, v in measured.channels.items() if k not in drop}
    m = Measurement(measured.time, channels, {k: measured.units[k] for k in channels}, measured.source)
    return diagnose(m, predicted, "force", ["velocity"], DiagnosisSettings())


@pytest.mark.slow
@pytest.mark.parametrize("effect", ["gas_force", "temperature", "seal_friction", "inertia", "hysteresis"])
def test_the_missing_effect_ranks_first_and_significant(effect):
    d = run((effect,))
    top = d.ranking[0]
    assert top.name == effect, d.summary
    assert top.significant and top.p_value < 1e-6
    assert top.additional_explained_variance > 0.05
    assert not d.consistent_with_noise
    assert effect in d.summary


def test_two_missing_effects_are_both_found_as_the_top_two():
    d = run(("gas_force", "temperature"))
    assert {e.name for e in d.ranking[:2]} == {"gas_force", "temperature"}, d.summary
    assert d.ranking[0].significant and d.ranking[1].significant
    # temperature is found beyond gas force, not merely alongside it
    assert d.effect("temperature").given == ("gas_force",)


def test_a_richer_family_adds_little_beyond_the_simpler_one_it_holds_and_a_different_one_adds_much():
    """Low-passed displacements hold the displacement: on a missing gas force they add nothing beyond it, while the
    friction sign, which the displacement cannot form, explains most of what is left of a missing seal friction."""
    measured, predicted = rig_case(("gas_force",))
    held = FamilyGains(measured, predicted, "force", ["velocity"]).explained("frequency_dependence", ("gas_force",))
    assert held.explained < 0.01 and held.p_value > 0.05
    measured, predicted = rig_case(("gas_force", "seal_friction"))
    other = FamilyGains(measured, predicted, "force", ["velocity"]).explained("seal_friction", ("gas_force",))
    assert other.explained > 0.5 and other.p_value < 1e-6


def test_sensor_noise_alone_is_consistent_with_noise():
    d = run(())
    assert not any(e.significant for e in d.ranking), [e.evidence for e in d.ranking[:2]]
    assert d.consistent_with_noise
    assert "consistent with noise" in d.summary
    assert d.test("whiteness").passed
    assert abs(d.residual_rms - 10.0) < 0.5  # the load cell's 10 N rms noise is all that is left


def test_temperature_without_its_channel_is_found_through_dissipated_energy():
    d = run(("temperature",), drop=("temperature",))
    top = d.ranking[0]
    assert top.name == "temperature" and top.significant
    assert top.missing_channels == ("temperature",)
    assert any("dissipated energy" in name for name in top.regressors)
    assert any("temperature" in note and "would confirm" in note for note in d.missing_measurements)


def test_temperature_with_its_channel_uses_it_and_misses_nothing():
    top = run(("temperature",)).ranking[0]
    assert top.name == "temperature" and top.missing_channels == ()
    assert any(name.startswith("temperature") for name in top.regressors)


def test_diagnosis_is_json_safe():
    d = run(("gas_force",))
    text = json.dumps(d.to_dict(), allow_nan=False)
    back = json.loads(text)
    assert back["ranking"][0]["name"] == "gas_force"
    assert {"statistic", "band", "verdict", "p_value"} <= set(back["tests"][0])


def test_whiteness_passes_white_noise_at_the_nominal_rate_and_flags_coloured_noise():
    settings = DiagnosisSettings()
    failures = sum(
        not whiteness_test(np.random.default_rng(seed).standard_normal(4000), settings).passed for seed in range(60)
    )
    assert failures <= 8  # nominal 5 % of 60 = 3; P(X > 8) < 0.5 % for Binomial(60, 0.05)
    for seed in range(10):
        coloured = lfilter([1.0], [1.0, -0.3], np.random.default_rng(seed).standard_normal(4000))
        assert not whiteness_test(coloured, settings).passed


def test_correlation_tests_see_unmodelled_dynamics_and_nonlinearity():
    rng = np.random.default_rng(5)
    n, settings = 4000, DiagnosisSettings()
    u = lfilter([1.0], [1.0, -0.8], rng.standard_normal(n))  # a coloured input
    noise = rng.standard_normal(n)

    def verdicts(residual):
        return {t.name: t.passed for t in residual_tests(residual, {"velocity": u}, settings)}

    clean = verdicts(noise)
    assert clean["cross_correlation[velocity]"] and clean["residual_vs_squared_input[velocity]"]
    delayed = verdicts(noise + 0.3 * np.concatenate([np.zeros(5), u[:-5]]))  # unmodelled delayed input
    assert not delayed["cross_correlation[velocity]"]
    squared = verdicts(noise + 0.2 * (u**2 - np.mean(u**2)))  # unmodelled even nonlinearity
    assert not squared["residual_vs_squared_input[velocity]"]
    assert squared["cross_correlation[velocity]"]  # u² is uncorrelated with u: only the nonlinear test sees it
    scaled = verdicts(noise * (1 + 0.5 * np.abs(u)))  # error size depends on the input
    assert not scaled["squared_residual_vs_squared_input[velocity]"]


def test_too_short_data_is_refused_with_a_clear_error():
    measured, predicted = rig_case(())
    short = measured.slice(0, 600)
    with pytest.raises(DiagnosisError, match=r"600 samples are too few.*at least 1000"):
        diagnose(short, predicted[:600], "force", ["velocity"], DiagnosisSettings())


@pytest.mark.parametrize(
    ("output", "inputs", "cut", "message"),
    [
        ("torque", ["velocity"], 0, "no output channel 'torque'"),
        ("force", ["acceleration"], 0, "model input.*'acceleration' not measured"),
        ("force", ["velocity"], 1, "predicted 'force' has shape"),
    ],
)
def test_bad_input_names_what_is_wrong(output, inputs, cut, message):
    measured, predicted = rig_case(())
    with pytest.raises(DiagnosisError, match=message):
        diagnose(measured, predicted[cut:], output, inputs, DiagnosisSettings())


def test_non_finite_prediction_is_refused():
    measured, predicted = rig_case(())
    bad = predicted.copy()
    bad[123] = np.nan
    with pytest.raises(DiagnosisError, match="not finite at sample 123"):
        diagnose(measured, bad, "force", ["velocity"], DiagnosisSettings())


def cross_fitted_polynomial(velocity: np.ndarray, force: np.ndarray, degree: int = 3) -> np.ndarray:
    """A velocity-only model: polynomial fitted on one half of the record, predicting the other, and back."""
    n, half = len(velocity), len(velocity) // 2
    predicted = np.empty(n)
    for fit, held in ((slice(0, half), slice(half, n)), (slice(half, n), slice(0, half))):
        predicted[held] = np.polyval(np.polyfit(velocity[fit], force[fit], degree), velocity[held])
    return predicted


def test_measured_friction_damper_residual_points_to_memory_not_noise():
    """BRFD slice, 2 Hz, 4 cycles: a velocity-only model misses the backlash loop; the diagnosis finds memory
    (travel since reversal) and displacement dependence, and sees no Coulomb term beyond a velocity polynomial."""
    m = load_brfd(BRFD / "2Hz36lbtension0.5amplitude.json.gz")
    d = diagnose(m, cross_fitted_polynomial(m["velocity"], m["force"]), "force", ["velocity"], DiagnosisSettings())
    assert not d.consistent_with_noise
    significant = [e.name for e in d.ranking if e.significant]
    assert "hysteresis" in significant, d.summary
    assert d.effect("hysteresis").additional_explained_variance > 0.3
    assert not d.effect("seal_friction").significant
    assert not d.test("whiteness").passed
