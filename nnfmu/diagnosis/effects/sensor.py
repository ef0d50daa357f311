"""A load-cell offset or slow drift: the measurement's error, not the component's."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from nnfmu.data import Measurement
from nnfmu.diagnosis.effects.base import Effect, Extension, NoExtension, Regressors
from nnfmu.diagnosis.effects.system import SystemEffect, Term
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.kinds import KindChannel
from nnfmu.models.features import FeatureSpec


class SensorOffset(Effect, SystemEffect):
    """A constant and a linear drift over the record. No extension, by design: the measurement, not the
    component, is at fault (the network's bias already holds a constant offset). In the system: a constant in one
    measured channel alone."""

    name = "sensor_offset"
    description = "load-cell offset or slow drift"
    requires = ()
    on_channel = True

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        t = signals.time - signals.time[0]
        span = t[-1] if t[-1] > 0 else 1.0
        matrix = np.column_stack([np.ones_like(t), t / span])
        names = ("1 (offset)", "time / record length (drift)")
        return Regressors(names, matrix, (), "constant offset and linear drift")

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """Always NoExtension: the fix is to correct the measurement."""
        return NoExtension(
            self.name,
            "a load-cell offset or slow drift belongs to the measurement, not to the "
            "component; correct the measurement (the network's bias already holds a "
            "constant offset)",
        )

    def terms(self, channels: Sequence[KindChannel], stiffness: Mapping[str, float]) -> tuple[Term, ...]:
        """None: the offset is the measured channel's, fitted on it directly."""
        return ()
