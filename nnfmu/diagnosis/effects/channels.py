"""Measured channels the model does not use, each a candidate effect of its own (`input:<channel>`): a lab records
more than the model was given (a semi-active damper's coil voltage or valve current, a supply pressure), and such a
channel, if the component responds to it, explains the residual better than any physical family can mimic it.

Which channels are candidates (`channel_effects`): every measured channel except the output, the model's inputs and
the quantities the physical families already cover: the motion (displacement, velocity, acceleration, rotation and
angle, their angular rates: inertia, hysteresis, gas force, friction, viscoelastic states all read them, in the
output's direction or not), loads (force, torque: another channel's output, not this component's input) and
temperature (the temperature family taps it). Candidates are made per record, not registered with the library.
"""

from __future__ import annotations

import numpy as np

from nnfmu.data import Measurement
from nnfmu.data.units import base_name
from nnfmu.diagnosis.effects.base import (
    Effect,
    Extension,
    NoExtension,
    Regressors,
    extended,
    need,
    with_delays,
    with_derived,
)
from nnfmu.diagnosis.effects.shared import CENTRED, low_pass
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals
from nnfmu.models.features import FeatureSpec, Lowpass

PREFIX = "input:"
# Base quantities some physical family covers: the motion, loads and temperature (see the module docstring).
COVERED = frozenset(
    {
        "displacement",
        "velocity",
        "acceleration",
        "rotation",
        "angle",
        "angular_velocity",
        "angular_acceleration",
        "force",
        "torque",
        "temperature",
        "time",
    }
)


class ChannelInput(Effect):
    """A measured channel the model does not use: the channel, its low-passes at `channel_taus` (a command acts
    through the lag of a coil or valve) and each times the prediction (a command scales a semi-active damper's
    force). The extension taps the channel at delay 0 and adds its low-passes as derived states."""

    requires = ()
    parameters = ("channel_taus",)

    def __init__(self, channel: str) -> None:
        self.channel = channel
        self.name = PREFIX + channel
        self.description = f"the measured channel {channel!r}, which the model does not use, and its dynamics"

    def missing(self, signals: EffectSignals) -> tuple[str, ...]:
        return () if self.channel in signals.raw else (self.channel,)

    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        x = np.asarray(signals.raw[self.channel], dtype=float)
        dt = signals.sample_period
        states = [x, *(low_pass(x, tau, dt) for tau in settings.channel_taus)]
        centred = [s - np.mean(s) for s in states]
        labels = [self.channel, *(f"lowpass({self.channel}, {tau:g} s)" for tau in settings.channel_taus)]
        names = (
            *(f"{label} - its mean" for label in labels),
            *(f"({label} - its mean) * predicted {signals.output}" for label in labels),
        )
        matrix = np.column_stack([*centred, *(c * signals.predicted for c in centred)])
        return Regressors(names, matrix, (), f"measured channel {self.channel!r} not used by the model" + CENTRED)

    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """The channel as a model input at delay 0 and lowpass(channel, tau) states at each of `channel_taus`."""
        if missing := need(self.name, self.channel, measurement):
            return missing
        states = tuple(Lowpass(self.channel, tau=tau) for tau in settings.channel_taus)
        unit = measurement.units.get(self.channel, "")
        taus = ", ".join(f"{tau:g}" for tau in settings.channel_taus)
        return extended(
            self.name,
            spec,
            with_derived(with_delays(spec, self.channel, (0,)), states),
            f"the measured channel {self.channel} [{unit}] as a model input at delay 0, with its "
            f"first-order low-passes at tau = {taus} s as derived states (the lag through which it acts)",
        )


def is_candidate(channel: str, model_inputs: tuple[str, ...], output: str) -> bool:
    """Whether `channel` is an `input:` candidate: not the output, not a model input, no covered quantity."""
    return channel != output and channel not in model_inputs and base_name(channel) not in COVERED


def channel_effects(measurement: Measurement, model_inputs: tuple[str, ...], output: str) -> list[Effect]:
    """One `ChannelInput` per candidate channel of `measurement`, in the record's channel order."""
    return [ChannelInput(name) for name in measurement.names if is_candidate(name, tuple(model_inputs), output)]
