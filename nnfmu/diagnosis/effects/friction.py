"""Coulomb friction of seals and guides: a smoothed sign of velocity."""

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
from nnfmu.diagnosis.effects.shared import derived_note, rms
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec, SmoothSign


def added_scale(settings: DiagnosisSettings) -> float:
    """The velocity scale (fraction of the rms velocity) the extension adds: the middle of the sorted
    `friction_scales` the diagnosis tries, between a sharp sign that noise flips and a soft one that is nearly
    linear in velocity."""
    scales = sorted(settings.friction_scales)
    return scales[len(scales) // 2]


class SealFriction(Effect):
    """tanh(velocity / scale) at each of `friction_scales` × the rms velocity; the extension adds the middle one."""

    name = "seal_friction"
    description = "Coulomb friction of seals and guides"
    requires = ("velocity",)
    parameters = ("friction_scales",)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        v = signals["velocity"]
        scales = [fraction * (rms(v) or 1.0) for fraction in settings.friction_scales]
        columns = [np.tanh(v / scale) for scale in scales]
        names = tuple(f"tanh(velocity / {scale:.3g} m/s)" for scale in scales)
        note = "smoothed sign of velocity (Coulomb friction) at velocity scales " + ", ".join(
            f"{x:.3g}" for x in scales
        )
        return Regressors(names, np.column_stack(columns), (), note + " m/s" + derived_note(signals, "velocity"))

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """smooth_sign(velocity, scale): tanh at the middle friction scale × the fit part's rms velocity."""
        velocity = channel(spec, "velocity")
        if missing := need(self.name, velocity, measurement):
            return missing
        fit_rms = rms(measurement[velocity][fit_rows])
        feature = SmoothSign(velocity, scale=added_scale(settings) * (fit_rms or 1.0))
        return extended(self.name, spec, with_derived(spec, (feature,)), f"{feature.name}: Coulomb friction sign")
