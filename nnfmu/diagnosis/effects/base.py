"""Turn a diagnosed effect into an extension of the model's feature spec: new input channels, delays or derived
states inside the step graph, each computable sample by sample from the component's inputs.

| effect | what is added |
|---|---|
| gas_force | displacement at delay 0 (preload and gas rate; the network's bias holds the preload) |
| seal_friction | smooth_sign(velocity, scale): tanh at `friction_scale` × the fit part's rms velocity |
| inertia | acceleration at delay 0 when measured, else velocity at delay 1 (with delay 0: a finite difference) |
| hysteresis | lowpass(velocity, tau) states at `memory_taus` (compliance lag, Maxwell-like memory) |
| backlash | stop(displacement, radius) states: the position inside a gap closed after each of the diagnosis's
  `reversal_fractions` of the fit part's mean travel between reversals (a play operator's state each) |
| temperature | the measured temperature channel, else lowpass_square(velocity, `thermal_tau`): a running mean
  square of velocity, the damper's dissipated power c·v² through the thermal lag of oil and tube |
| frequency_dependence | lowpass(displacement, tau) states at `frequency_taus` |
| amplitude_dependence | lowpass_square(displacement, `amplitude_tau`): the running amplitude² |
| sensor_offset | nothing: a load-cell offset or drift is the measurement's, not the component's (reported) |

Channel names carry the output's direction prefix (`axial_force` -> `axial_displacement`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.data import Measurement
from nnfmu.models.features import Derived, FeatureSpec, Lowpass, LowpassSquare, SmoothSign, Stop, Tap

from .effects import backlash_radii
from .loop_settings import LoopSettings
from .signals import direction_prefix


@dataclass(frozen=True)
class Extension:
    """The extended spec for one effect, the feature names it adds, and what was added in words."""

    effect: str
    spec: FeatureSpec
    added: tuple[str, ...]
    note: str


@dataclass(frozen=True)
class NoExtension:
    """Why an effect cannot be added to the network (a channel is not measured, it is not the component's, ...)."""

    effect: str
    reason: str
    missing_channels: tuple[str, ...] = ()


def _with_delays(spec: FeatureSpec, channel: str, delays: tuple[int, ...]) -> FeatureSpec:
    """`spec` with `channel` tapped at `delays` as well (a new tap goes after the existing ones)."""
    taps = list(spec.taps)
    for i, tap in enumerate(taps):
        if tap.channel == channel:
            taps[i] = Tap(channel, tuple(sorted(set(tap.delays) | set(delays))))
            break
    else:
        taps.append(Tap(channel, tuple(delays)))
    return FeatureSpec(taps=tuple(taps), output=spec.output, derived=spec.derived)


def _with_derived(spec: FeatureSpec, derived: tuple[Derived, ...]) -> FeatureSpec:
    known = {d.name for d in spec.derived}
    fresh = tuple(d for d in derived if d.name not in known)
    return FeatureSpec(taps=spec.taps, output=spec.output, derived=spec.derived + fresh)


def _result(effect: str, old: FeatureSpec, new: FeatureSpec, note: str) -> Extension | NoExtension:
    added = tuple(name for name in new.feature_names if name not in old.feature_names)
    if not added:
        return NoExtension(effect, f"the model already has the features for {effect} ({note}); a larger network or "
                                   f"more data may be needed instead")
    return Extension(effect, new, added, note)


def extend_spec(
    effect: str, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: LoopSettings
) -> Extension | NoExtension:
    """The extension of `spec` for the effect named `effect`, or why there is none. `fit_rows` (indices) set the
    friction scale from the fit part's rms velocity."""
    prefix = direction_prefix(spec.output)
    velocity, displacement = prefix + "velocity", prefix + "displacement"
    acceleration, temperature = prefix + "acceleration", "temperature"

    def need(channel: str) -> NoExtension | None:
        if channel in measurement:
            return None
        return NoExtension(effect, f"{effect} needs the measured channel {channel!r} as a model input; the data have "
                                   f"{', '.join(measurement.names)}", (channel,))

    if effect == "sensor_offset":
        return NoExtension(effect, "a load-cell offset or slow drift belongs to the measurement, not to the component; "
                                   "correct the measurement (the network's bias already holds a constant offset)")
    if effect == "gas_force":
        return need(displacement) or _result(effect, spec, _with_delays(spec, displacement, (0,)),
                                             f"{displacement} at delay 0")
    if effect == "seal_friction":
        if missing := need(velocity):
            return missing
        rms = float(np.sqrt(np.mean(np.square(measurement[velocity][fit_rows]))))
        feature = SmoothSign(velocity, scale=settings.friction_scale * (rms or 1.0))
        return _result(effect, spec, _with_derived(spec, (feature,)), f"{feature.name}: Coulomb friction sign")
    if effect == "inertia":
        if acceleration in measurement:
            return _result(effect, spec, _with_delays(spec, acceleration, (0,)), f"{acceleration} at delay 0")
        if missing := need(velocity):
            return missing
        return _result(effect, spec, _with_delays(spec, velocity, (0, 1)),
                       f"{velocity} at delays 0 and 1 (acceleration as a finite difference; "
                       f"no {acceleration} measured)")
    if effect == "hysteresis":
        if missing := need(velocity):
            return missing
        states = tuple(Lowpass(velocity, tau=tau) for tau in settings.memory_taus)
        return _result(effect, spec, _with_derived(spec, states), ", ".join(d.name for d in states) + ": memory states")
    if effect == "backlash":
        if missing := need(displacement):
            return missing
        dt = measurement.sample_period
        rate = (measurement[velocity][fit_rows] if velocity in measurement
                else np.gradient(measurement[displacement][fit_rows], dt))
        radii = backlash_radii(rate, dt, settings.diagnosis.reversal_fractions)
        stops = tuple(Stop(displacement, radius=float(f"{r:.3g}")) for r in radii)
        return _result(effect, spec, _with_derived(spec, stops),
                       ", ".join(d.name for d in stops) + ": position inside the backlash gap (play-operator states)")
    if effect == "temperature":
        if temperature in measurement:
            return _result(effect, spec, _with_delays(spec, temperature, (0,)), "the measured temperature channel")
        if missing := need(velocity):
            return missing
        state = LowpassSquare(velocity, tau=settings.thermal_tau)
        return _result(effect, spec, _with_derived(spec, (state,)),
                       f"{state.name}: running mean square of velocity (dissipated power c·v² through the thermal "
                       f"lag) in place of the unmeasured temperature")
    if effect == "frequency_dependence":
        if missing := need(displacement):
            return missing
        states = tuple(Lowpass(displacement, tau=tau) for tau in settings.frequency_taus)
        return _result(effect, spec, _with_derived(spec, states),
                       ", ".join(d.name for d in states) + ": viscoelastic internal states")
    if effect == "amplitude_dependence":
        if missing := need(displacement):
            return missing
        state = LowpassSquare(displacement, tau=settings.amplitude_tau)
        return _result(effect, spec, _with_derived(spec, (state,)), f"{state.name}: running amplitude²")
    return NoExtension(effect, f"no feature-spec extension is defined for the effect {effect!r}")
