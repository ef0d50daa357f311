"""Viscoelastic behaviour of rubber and oil: internal states that make the force depend on the excitation's
frequency (Maxwell elements) and on its amplitude."""

from __future__ import annotations

import numpy as np

from nnfmu.data import Measurement
from nnfmu.diagnosis.effects.base import (
    Effect,
    Extension,
    NoExtension,
    Regressors,
    channel,
    extended,
    need,
    with_derived,
)
from nnfmu.diagnosis.effects.shared import CENTRED, derived_note, low_pass
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec, Lowpass, LowpassSquare


class FrequencyDependence(Effect):
    """The displacement minus its low-pass at each of `frequency_taus`; the extension adds those low-pass states."""

    name = "frequency_dependence"
    description = "viscoelastic internal states"
    requires = ("displacement",)
    parameters = ("frequency_taus",)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        x, dt = signals["displacement"], signals.sample_period
        taus = settings.frequency_taus
        columns = [x - low_pass(x, tau, dt) for tau in taus]
        names = tuple(f"displacement - lowpass(displacement, {tau:g} s)" for tau in taus)
        note = "viscoelastic internal states (Maxwell elements) at time constants " + ", ".join(f"{t:g}" for t in taus)
        return Regressors(names, np.column_stack(columns), (), note + " s" + derived_note(signals, "displacement"))

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """lowpass(displacement, tau) states at `frequency_taus`."""
        displacement = channel(spec, "displacement")
        if missing := need(self.name, displacement, measurement):
            return missing
        states = tuple(Lowpass(displacement, tau=tau) for tau in settings.frequency_taus)
        return extended(
            self.name,
            spec,
            with_derived(spec, states),
            ", ".join(d.name for d in states) + ": viscoelastic internal states",
        )


class AmplitudeDependence(Effect):
    """The running amplitude (√2·rms over `amplitude_tau`) scaling the prediction and the displacement; the
    extension adds the running mean square of displacement at the same `amplitude_tau`."""

    name = "amplitude_dependence"
    description = "force scaled by the running amplitude"
    requires = ("displacement",)
    parameters = ("amplitude_tau",)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        x, dt, window = signals["displacement"], signals.sample_period, settings.amplitude_tau
        first = x[: max(2, int(round(window / dt)))]  # start the running values where the first window puts them
        mean = low_pass(x, window, dt, float(np.mean(first)))
        spread = low_pass((x - mean) ** 2, window, dt, float(np.var(first)))
        amplitude = np.sqrt(2 * np.maximum(spread, 0.0))
        amplitude -= np.mean(amplitude)
        names = (
            f"(running amplitude - its mean) * predicted {signals.output}",
            "(running amplitude - its mean) * displacement",
        )
        note = f"running displacement amplitude (√2·rms over {window:g} s) scaling the force and the stiffness"
        return Regressors(names, np.column_stack([amplitude * signals.predicted, amplitude * x]), (), note + CENTRED)

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """lowpass_square(displacement, `amplitude_tau`): the running amplitude²."""
        displacement = channel(spec, "displacement")
        if missing := need(self.name, displacement, measurement):
            return missing
        state = LowpassSquare(displacement, tau=settings.amplitude_tau)
        return extended(self.name, spec, with_derived(spec, (state,)), f"{state.name}: running amplitude²")
