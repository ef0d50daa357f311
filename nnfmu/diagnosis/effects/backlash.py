"""Play at motion reversals: a dead zone, then re-engagement over the gap's travel (Prandtl-Ishlinskii stops)."""

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
from nnfmu.diagnosis.effects.shared import backlash_radii, derived_note, stop_operator
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec, Stop


class Backlash(Effect):
    """Stop operators of the displacement at gaps closed after each of `reversal_fractions` of the mean travel
    between reversals; the extension adds the same stops (radii from the fit part) as play-operator states."""

    name = "backlash"
    description = "play at motion reversals: dead zone, then re-engagement over the gap's travel"
    requires = ("displacement", "velocity")
    parameters = ("reversal_fractions",)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        radii = backlash_radii(signals["velocity"], signals.sample_period, settings.reversal_fractions)
        columns = [stop_operator(signals["displacement"], r) for r in radii]
        names = tuple(f"stop(displacement, radius={r:.3g} m)" for r in radii)
        fractions = ", ".join(f"{f:g}" for f in settings.reversal_fractions)
        note = (
            "backlash (play) at motion reversals: the displacement's stop operators (position inside a gap of "
            f"half-width {', '.join(f'{r:.3g}' for r in radii)} m, closed after {fractions} of the mean travel "
            "between reversals), a Prandtl-Ishlinskii bank"
        )
        return Regressors(names, np.column_stack(columns), (), note + derived_note(signals, "displacement"))

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """stop(displacement, radius) states: the position inside a gap closed after each reversal fraction of the
        fit part's mean travel between reversals (a play operator's state each)."""
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
            self.name,
            spec,
            with_derived(spec, stops),
            ", ".join(d.name for d in stops) + ": position inside the backlash gap (play-operator states)",
        )
