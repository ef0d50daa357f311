"""The stop-operator family both rate-independent memories share: the displacement's stop operators (a
Prandtl-Ishlinskii bank) at gaps closed after each of `reversal_fractions` of the mean travel between reversals. The
same columns fit mechanical play (`backlash`: a dead zone, then re-engagement) and a seal's pre-sliding stiffness
(`presliding_friction`: a Jenkins element, stiff then sliding); which of the two a residual shows is read from its
shape after reversals (`nnfmu.diagnosis.stop_reading`)."""

from __future__ import annotations

from typing import ClassVar

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
from nnfmu.diagnosis.effects.shared import backlash_radii, derived_note, stop_operator
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec, Stop


class StopFamily(Effect):
    """Stop operators of the displacement, in the diagnosis and as play-operator states in the step graph; a
    subclass says what physics they stand for (`meaning`, `state_meaning`) and which shape after a reversal
    (`shape`: "dead_zone" or "elastic_plastic") names it."""

    requires = ("displacement", "velocity")
    parameters = ("reversal_fractions",)
    shape: ClassVar[str]
    meaning: ClassVar[str]
    state_meaning: ClassVar[str]

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        radii = backlash_radii(signals["velocity"], signals.sample_period, settings.reversal_fractions)
        columns = [stop_operator(signals["displacement"], r) for r in radii]
        names = tuple(f"stop(displacement, radius={r:.3g} m)" for r in radii)
        fractions = ", ".join(f"{f:g}" for f in settings.reversal_fractions)
        note = (
            f"{self.meaning}: the displacement's stop operators (half-width "
            f"{', '.join(f'{r:.3g}' for r in radii)} m, closed after {fractions} of the mean travel between "
            "reversals), a Prandtl-Ishlinskii bank"
        )
        return Regressors(names, np.column_stack(columns), (), note + derived_note(signals, "displacement"))

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """stop(displacement, radius) states, each closed after a reversal fraction of the fit part's mean travel
        between reversals (a play operator's state each)."""
        velocity, displacement = channel(spec, "velocity"), channel(spec, "displacement")
        if missing := need(self.name, displacement, measurement):
            return missing
        dt = measurement.sample_period
        rate = (
            measurement[velocity][fit_rows]
            if velocity in measurement
            else np.gradient(measurement[displacement][fit_rows], dt)
        )
        radii = backlash_radii(rate, dt, settings.reversal_fractions)
        stops = tuple(Stop(displacement, radius=float(f"{r:.3g}")) for r in radii)
        return extended(
            self.name, spec, with_derived(spec, stops), ", ".join(d.name for d in stops) + f": {self.state_meaning}"
        )
