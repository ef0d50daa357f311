"""The moving mass between the load cell and the actuator: mass times acceleration."""

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
    with_delays,
)
from nnfmu.diagnosis.effects.shared import derived_note
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec


class Inertia(Effect):
    """The acceleration; the extension taps it when measured, else the velocity at delays 0 and 1."""

    name = "inertia"
    description = "moving mass between load cell and actuator"
    requires = ("acceleration",)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        a = signals["acceleration"]
        note = "mass times acceleration" + derived_note(signals, "acceleration")
        return Regressors(("acceleration [m/s^2]",), a[:, None], (), note)

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """The acceleration at delay 0 when measured, else the velocity at delay 1 (with delay 0: a finite
        difference)."""
        velocity, acceleration = channel(spec, "velocity"), channel(spec, "acceleration")
        if acceleration in measurement:
            return extended(self.name, spec, with_delays(spec, acceleration, (0,)), f"{acceleration} at delay 0")
        if missing := need(self.name, velocity, measurement):
            return missing
        return extended(
            self.name,
            spec,
            with_delays(spec, velocity, (0, 1)),
            f"{velocity} at delays 0 and 1 (acceleration as a finite difference; no {acceleration} measured)",
        )
