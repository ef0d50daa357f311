"""Memory of the force: a compliance lag (Maxwell-like) and the force build-up over the travel after a motion
reversal (Dahl-like)."""

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
from nnfmu.diagnosis.effects.shared import delayed, derived_note, mean_stroke, reversal_travel
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec, Lowpass


def added_taus(settings: DiagnosisSettings) -> tuple[float, ...]:
    """The low-pass time constants [s] the extension adds: the shortest and the longest of the `memory_times` the
    diagnosis tries, two states spanning the memory the network then interpolates within."""
    return tuple(sorted({min(settings.memory_times), max(settings.memory_times)}))


class Hysteresis(Effect):
    """The model's force delayed by each of `memory_times` and a decaying build-up after each reversal (at
    `reversal_fractions` of the mean travel); the extension adds low-pass states of velocity."""

    name = "hysteresis"
    description = "memory: compliance lag, force build-up after reversals"
    requires = ("velocity",)
    parameters = ("memory_times", "reversal_fractions")

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        s, dt = signals, signals.sample_period
        delays = sorted({max(1, int(round(delay / dt))) for delay in settings.memory_times})
        columns = [delayed(s.predicted, d) - s.predicted for d in delays]
        names = [f"predicted {s.output} delayed {d * dt * 1e3:.3g} ms - predicted {s.output}" for d in delays]
        direction, travel = reversal_travel(s["velocity"], dt)
        stroke = mean_stroke(s["velocity"], dt)
        for fraction in settings.reversal_fractions:
            length = fraction * stroke if stroke > 0 else 1.0
            columns.append(direction * np.exp(-travel / length))
            names.append(f"sign(velocity)*exp(-travel since reversal / {length:.3g} m)")
        note = (
            "memory: the model's force delayed (compliance lag) and the force build-up over the travel after a motion "
            f"reversal (Dahl-like, backlash), at {', '.join(f'{f:g}' for f in settings.reversal_fractions)} of the "
            f"mean travel between reversals ({stroke:.3g} m)"
        )
        return Regressors(tuple(names), np.column_stack(columns), (), note + derived_note(s, "velocity"))

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """lowpass(velocity, tau) states at the shortest and longest memory time (compliance lag, Maxwell-like
        memory)."""
        velocity = channel(spec, "velocity")
        if missing := need(self.name, velocity, measurement):
            return missing
        states = tuple(Lowpass(velocity, tau=tau) for tau in added_taus(settings))
        return extended(
            self.name, spec, with_derived(spec, states), ", ".join(d.name for d in states) + ": memory states"
        )
