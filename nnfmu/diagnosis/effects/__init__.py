"""The effect library: ONE registry of the physical effects a model may lack, each with both halves of the loop
(regressors for the diagnosis, a feature-spec extension for the retraining; see `base.Effect`), under a stable
name. Grouped by physical family, one module each. Beside them, per record, every measured channel the model does
not use is a candidate of its own, `input:<channel>` (`channels`); `effects_for` merges both for one diagnosis and
`find_effect` looks either kind up by name. `SYSTEM_EFFECTS`: the effects the vehicle loop attributes in the
co-simulation, each with its system half (`system.SystemEffect`: terms on a component's network, or a measured
channel's own error); a component kind names those it may show (`ComponentKind.loop_effects`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TypeVar

from nnfmu.data import Measurement
from nnfmu.diagnosis.effects.backlash import Backlash
from nnfmu.diagnosis.effects.base import Effect, Extension, NoExtension, Regressors
from nnfmu.diagnosis.effects.channels import PREFIX, ChannelInput, channel_effects
from nnfmu.diagnosis.effects.friction import SealFriction
from nnfmu.diagnosis.effects.gas_spring import GasForce
from nnfmu.diagnosis.effects.hysteresis import Hysteresis
from nnfmu.diagnosis.effects.inertia import Inertia
from nnfmu.diagnosis.effects.presliding import PreslidingFriction
from nnfmu.diagnosis.effects.sensor import SensorOffset
from nnfmu.diagnosis.effects.stiffness import Stiffness
from nnfmu.diagnosis.effects.stop_family import StopFamily
from nnfmu.diagnosis.effects.system import SystemEffect, Term
from nnfmu.diagnosis.effects.temperature import Temperature
from nnfmu.diagnosis.effects.viscoelastic import AmplitudeDependence, FrequencyDependence
from nnfmu.diagnosis.errors import DiagnosisError

Named = TypeVar("Named", Effect, SystemEffect)


def _registry(*effects: Named) -> dict[str, Named]:
    """Name -> effect in library order; a name given twice is a programming error."""
    registry: dict[str, Named] = {}
    for effect in effects:
        if effect.name in registry:
            raise ValueError(f"two effects are named {effect.name!r}")
        registry[effect.name] = effect
    return registry


EFFECTS: dict[str, Effect] = _registry(
    SealFriction(),
    GasForce(),
    Hysteresis(),
    Backlash(),
    PreslidingFriction(),
    Inertia(),
    Temperature(),
    FrequencyDependence(),
    AmplitudeDependence(),
    SensorOffset(),
)

# The vehicle loop's effects: a new one is its module (a `SystemEffect`, or an `Effect` that is one too) and a line
# here.
SYSTEM_EFFECTS: dict[str, SystemEffect] = _registry(GasForce(), Stiffness(), SensorOffset())


def select_effects(names: tuple[str, ...] | None) -> list[Effect]:
    """The effects named (None: all, in library order); an unknown name raises DiagnosisError listing the library."""
    if names is None:
        return list(EFFECTS.values())
    unknown = [name for name in names if name not in EFFECTS]
    if unknown:
        raise DiagnosisError(f"unknown effect(s) {', '.join(map(repr, unknown))}; the library has {', '.join(EFFECTS)}")
    return [EFFECTS[name] for name in names]


def effects_for(
    measurement: Measurement, model_inputs: Sequence[str], output: str, names: tuple[str, ...] | None
) -> list[Effect]:
    """The effects one diagnosis ranks: the library's and the record's `input:` candidates (`channel_effects`);
    None: all of them, library first; else those named, in the order asked (DiagnosisError for an unknown name)."""
    candidates = {e.name: e for e in channel_effects(measurement, tuple(model_inputs), output)}
    if names is None:
        return [*EFFECTS.values(), *candidates.values()]
    known = {**EFFECTS, **candidates}
    unknown = [name for name in names if name not in known]
    if unknown:
        raise DiagnosisError(
            f"unknown effect(s) {', '.join(map(repr, unknown))}; the library has {', '.join(EFFECTS)}"
            f" and {measurement.source} the channel candidates {', '.join(candidates) or '(none)'}"
        )
    return [known[name] for name in names]


def find_effect(name: str) -> Effect:
    """The effect named `name`: the library's, or the channel candidate `input:<channel>` (DiagnosisError else)."""
    if name.startswith(PREFIX) and len(name) > len(PREFIX):
        return ChannelInput(name[len(PREFIX) :])
    (effect,) = select_effects((name,))
    return effect


__all__ = [
    "EFFECTS",
    "SYSTEM_EFFECTS",
    "ChannelInput",
    "Effect",
    "Extension",
    "NoExtension",
    "Regressors",
    "StopFamily",
    "SystemEffect",
    "Term",
    "channel_effects",
    "effects_for",
    "find_effect",
    "select_effects",
]
