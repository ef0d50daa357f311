"""The gas spring of a damper: a preload and a force rising with displacement."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

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
from nnfmu.diagnosis.effects.system import SystemEffect, Term
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.kinds import KindChannel
from nnfmu.models.features import FeatureSpec

PROBE_PRELOAD = -100.0  # [N] the preload (pushing out: tension positive) and
PROBE_RATE = 2000.0  # [N/m] the gas rate the vehicle loop probes its sensitivities with


class GasForce(Effect, SystemEffect):
    """A constant and the displacement; the extension taps the displacement (the network's bias holds the
    preload). In the system: a preload and a rate times the stroke on the force of the kind's first channel."""

    name = "gas_force"
    description = "gas spring: preload and displacement dependence"
    requires = ("displacement",)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        x = signals["displacement"]
        matrix = np.column_stack([np.ones_like(x), x])
        note = (
            "preload (constant) and spring rate (displacement); the constant alone cannot be told from a sensor offset"
        )
        return Regressors(("1 (preload)", "displacement [m]"), matrix, (), note + derived_note(signals, "displacement"))

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """The displacement at delay 0 (preload and gas rate)."""
        displacement = channel(spec, "displacement")
        return need(self.name, displacement, measurement) or extended(
            self.name, spec, with_delays(spec, displacement, (0,)), f"{displacement} at delay 0"
        )

    def terms(self, channels: Sequence[KindChannel], stiffness: Mapping[str, float]) -> tuple[Term, ...]:
        """-preload + rate x on the first channel's force (a damper's stroke), at the probe values."""
        stroke = channels[0]
        return (
            Term(stroke.force, None, PROBE_PRELOAD, stroke.force_unit),
            Term(stroke.force, stroke.position, PROBE_RATE, stroke.position_unit),
        )
