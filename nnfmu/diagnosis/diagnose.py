"""Diagnose a model's residual on data not used to fit it: residual tests, then the effect library ranked by the
variance each effect explains out of sample, and a verdict in words."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from nnfmu.data import DataError, Measurement, check_measurement
from nnfmu.diagnosis.effects import EFFECTS, StopFamily, effects_for, find_effect
from nnfmu.diagnosis.errors import DiagnosisError
from nnfmu.diagnosis.evidence import Diagnosis, EffectEvidence, effect_evidence
from nnfmu.diagnosis.ranking import (
    GainTest,
    cross_fit_errors,
    extend_base,
    fold_mask,
    gain_test,
    rank_effects,
    recalibration,
)
from nnfmu.diagnosis.residual_tests import ResidualTest, residual_tests
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals, build_signals
from nnfmu.diagnosis.stop_reading import keep_reading, read_stops, supported

STOPS = {name for name, effect in EFFECTS.items() if isinstance(effect, StopFamily)}


def _check_input(
    m: Measurement, predicted: np.ndarray, output: str, inputs: tuple[str, ...], settings: DiagnosisSettings
) -> None:
    """Raise DiagnosisError naming the source and what is wrong with the channels, the length or the prediction."""
    if output not in m.channels:
        raise DiagnosisError(f"{m.source}: no output channel {output!r} (has: {', '.join(m.channels)})")
    absent = [name for name in inputs if name not in m.channels]
    if absent:
        raise DiagnosisError(
            f"{m.source}: model input(s) {', '.join(map(repr, absent))} not measured (has: {', '.join(m.channels)})"
        )
    if output in inputs:
        raise DiagnosisError(f"{m.source}: the output {output!r} cannot also be a model input")
    if len(m.time) < settings.min_samples:
        raise DiagnosisError(
            f"{m.source}: {len(m.time)} samples are too few to diagnose a residual; at least {settings.min_samples} "
            f"needed (DiagnosisSettings.min_samples)"
        )
    try:
        check_measurement(m, required=(output, *inputs), min_samples=settings.min_samples)
    except DataError as err:
        raise DiagnosisError(f"unusable measurement: {err}") from None
    if predicted.shape != m.time.shape:
        raise DiagnosisError(
            f"{m.source}: predicted {output!r} has shape {predicted.shape}, the measurement {m.time.shape}"
        )
    bad = np.nonzero(~np.isfinite(predicted))[0]
    if bad.size:
        raise DiagnosisError(f"{m.source}: predicted {output!r} is not finite at sample {bad[0]} ({predicted[bad[0]]})")


def _missing_measurements(ranking: list[EffectEvidence], consistent: bool, tests: list[ResidualTest]) -> list[str]:
    """Which measurements would help: proxies behind significant effects, untestable effects, unexplained structure."""
    notes = []
    for e in ranking:
        if e.significant and e.missing_channels:
            notes.append(
                f"{e.name} is significant through a proxy; measuring {', '.join(e.missing_channels)} would confirm "
                f"and sharpen it"
            )
        elif not e.testable:
            notes.append(f"{e.name} could not be tested: {', '.join(e.missing_channels)} not measured")
    if not consistent and not any(e.significant for e in ranking):
        failed = [t.name for t in tests if not t.passed]
        notes.append(
            "the residual has structure (" + ", ".join(failed) + ") that no effect computable from the measured "
            "channels explains; it may need a measurement the data lack"
        )
    return notes


def _summary(ranking: list[EffectEvidence], consistent: bool, tests: list[ResidualTest]) -> str:
    """The verdict in one sentence."""
    if consistent:
        return (
            "the residual is consistent with noise: no residual test rejects at the family-wise level and no effect "
            "explains it significantly"
        )
    found = [e for e in ranking if e.significant]
    if not found:
        failed = ", ".join(t.name for t in tests if not t.passed)
        return f"the residual is not noise ({failed} fail) but no effect in the library explains it significantly"
    parts = [f"{e.name} ({e.additional_explained_variance:.1%} more of the residual variance)" for e in found]
    return "missing effect(s), in order of evidence: " + "; ".join(parts)


def _residual_setup(
    measurement: Measurement, predicted: np.ndarray, output: str, inputs: tuple[str, ...], settings: DiagnosisSettings
) -> tuple[EffectSignals, np.ndarray, np.ndarray]:
    """The checked input's effect signals, residual (measured - predicted) and recalibration columns (predicted
    output and model inputs), shared by `diagnose` and `FamilyGains`."""
    predicted = np.asarray(predicted, dtype=float)
    _check_input(measurement, predicted, output, inputs, settings)
    signals = build_signals(measurement, predicted, output, inputs)
    base = recalibration(signals, {name: np.asarray(measurement.channels[name], dtype=float) for name in inputs})
    return signals, signals.measured - predicted, base


def diagnose(
    measurement: Measurement,
    predicted: np.ndarray,
    output: str,
    model_inputs: Sequence[str],
    settings: DiagnosisSettings = DiagnosisSettings(),
) -> Diagnosis:
    """Diagnose residual = measurement[output] - predicted (shape (n,)) of a model driven by `model_inputs`.

    `measurement` must be data the model was not fitted on. Returns the residual tests, the effect ranking and
    whether the residual is consistent with noise (family-wise: every test passes at alpha/len(tests) and no effect
    is significant). Raises DiagnosisError naming the source and the channel or value for unusable input.
    """
    inputs = tuple(model_inputs)
    signals, residual, base = _residual_setup(measurement, predicted, output, inputs, settings)
    families = effects_for(measurement, inputs, output, settings.effects)
    if np.std(residual) <= 1e-12 * np.sqrt(np.mean(signals.measured**2)):
        raise DiagnosisError(
            f"{measurement.source}: the residual of {output!r} is constant ({np.mean(residual):g}): the prediction "
            f"equals the measurement up to an offset, so there is nothing to diagnose (was the model fed the "
            f"measured output?)"
        )
    others = [name for name in measurement.channels if name != output and name not in inputs]
    tested = {name: np.asarray(measurement.channels[name], dtype=float) for name in (*inputs, *others)}
    tests = residual_tests(residual, tested, settings)
    recalibrated = cross_fit_errors(residual, base, fold_mask(len(residual), settings.blocks))
    reading = read_stops(signals, recalibrated, settings) if signals.has("displacement") else None
    asked = families
    if reading is not None:
        families = keep_reading(families, reading)
    ranking = effect_evidence(rank_effects(signals, families, base, settings), settings.alpha)
    if reading is not None:  # play only where its stop family is significant in the ranking
        stops = [e for e in ranking if e.name == reading.effect]
        reading = supported(
            reading, bool(stops and stops[0].significant), stops[0].additional_explained_variance if stops else None
        )
        if reading.effect is None and keep_reading(asked, reading) != asked:
            kept = [e for e in ranking if e.name not in STOPS]
            ranking = [replace(e, rank=k) for k, e in enumerate(kept, start=1)]
    if reading is not None:  # the stop family's evidence says which physics its shape shows, and why
        ranking = [replace(e, evidence=f"{e.evidence}; {reading.text}") if e.name in STOPS else e for e in ranking]
    tests_pass = all(t.p_value >= settings.alpha / len(tests) for t in tests)
    consistent = tests_pass and not any(e.significant for e in ranking)
    return Diagnosis(
        source=measurement.source,
        output=output,
        model_inputs=inputs,
        samples=len(measurement),
        sample_period=measurement.sample_period,
        residual_rms=float(np.sqrt(np.mean(residual**2))),
        recalibration_explained=float(1 - np.sum(recalibrated**2) / np.sum(residual**2)),
        tests=tuple(tests),
        ranking=tuple(ranking),
        consistent_with_noise=consistent,
        unknown_to_model=signals.unknown_to_model,
        missing_measurements=tuple(_missing_measurements(ranking, consistent, tests)),
        summary=_summary(ranking, consistent, tests),
        stop_reading=reading,
    )


class FamilyGains:
    """What one effect family explains of a model's residual out of sample beyond the recalibration and other
    families, with its Diebold-Mariano test: whether a richer family holds more than a simpler one that spans most of
    it (three low-passed displacements against the displacement). The signals, the recalibration and each family's
    regressors are computed once per residual. Same input checks and set-up as `diagnose`."""

    def __init__(
        self,
        measurement: Measurement,
        predicted: np.ndarray,
        output: str,
        model_inputs: Sequence[str],
        settings: DiagnosisSettings = DiagnosisSettings(),
    ) -> None:
        self._signals, self._residual, self._base = _residual_setup(
            measurement, predicted, output, tuple(model_inputs), settings
        )
        self._settings = settings
        self._fold = fold_mask(len(self._residual), settings.blocks)
        self._matrices: dict[str, np.ndarray] = {}

    def _matrix(self, effect: str) -> np.ndarray:
        if effect not in self._matrices:
            self._matrices[effect] = find_effect(effect).regressors(self._signals, self._settings).matrix
        return self._matrices[effect]

    def explained(self, effect: str, given: Sequence[str] = ()) -> GainTest:
        """`effect`'s gain beyond the recalibration and the `given` families' regressors."""
        base = self._base
        for name in given:
            base = extend_base(base, self._matrix(name))
        return gain_test(self._residual, base, self._matrix(effect), self._fold)
