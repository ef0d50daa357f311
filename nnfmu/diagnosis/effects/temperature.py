"""Damping fade with oil temperature: the measured temperature, or the heating that drives it."""

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
    with_derived,
)
from nnfmu.diagnosis.effects.shared import CENTRED
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec, LowpassSquare

TEMPERATURE = "temperature"


class Temperature(Effect):
    """The temperature channel's change, alone and scaling the prediction; without a temperature channel the
    dissipated energy ∫F·v dt stands in (and the regressors name the channel that would measure it directly). The
    extension taps the temperature, else adds a running mean square of velocity at `thermal_tau`."""

    name = "temperature"
    description = "damping fade with oil temperature"
    requires = ("velocity",)
    parameters = ("thermal_tau",)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        s = signals
        if s.has(TEMPERATURE):
            change = s[TEMPERATURE] - np.mean(s[TEMPERATURE])
            names = ("temperature - its mean [K]", f"(temperature - its mean) * predicted {s.output}")
            note = "measured temperature channel"
            return Regressors(names, np.column_stack([change, change * s.predicted]), (), note + CENTRED)
        energy = np.cumsum(s.measured * s["velocity"]) * s.sample_period
        energy -= np.mean(energy)
        names = ("dissipated energy - its mean [J]", f"(dissipated energy - its mean) * predicted {s.output}")
        note = (
            f"no temperature channel: dissipated energy ∫{s.output}·velocity dt as the proxy of heating; a temperature "
            "channel (oil or tube thermocouple, temperature [K]) would measure it directly"
        )
        return Regressors(names, np.column_stack([energy, energy * s.predicted]), (TEMPERATURE,), note + CENTRED)

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """The measured temperature channel, else lowpass_square(velocity, `thermal_tau`): a running mean square of
        velocity, the damper's dissipated power c·v² through the thermal lag of oil and tube."""
        if TEMPERATURE in measurement:
            return extended(self.name, spec, with_delays(spec, TEMPERATURE, (0,)), "the measured temperature channel")
        velocity = channel(spec, "velocity")
        if missing := need(self.name, velocity, measurement):
            return missing
        state = LowpassSquare(velocity, tau=settings.thermal_tau)
        return extended(
            self.name,
            spec,
            with_derived(spec, (state,)),
            f"{state.name}: running mean square of velocity (dissipated power c·v² through the thermal "
            f"lag) in place of the unmeasured temperature",
        )
