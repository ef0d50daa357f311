"""The effect library: ONE registry of the physical effects a model may lack, each with both halves of the loop
(regressors for the diagnosis, a feature-spec extension for the retraining; see `base.Effect`), under a stable
name. Grouped by physical family, one module each."""

from __future__ import annotations

from nnfmu.diagnosis.effects.backlash import Backlash
from nnfmu.diagnosis.effects.base import Effect, Extension, NoExtension, Regressors
from nnfmu.diagnosis.effects.friction import SealFriction
from nnfmu.diagnosis.effects.gas_spring import GasForce
from nnfmu.diagnosis.effects.hysteresis import Hysteresis
from nnfmu.diagnosis.effects.inertia import Inertia
from nnfmu.diagnosis.effects.sensor import SensorOffset
from nnfmu.diagnosis.effects.temperature import Temperature
from nnfmu.diagnosis.effects.viscoelastic import AmplitudeDependence, FrequencyDependence
from nnfmu.diagnosis.errors import DiagnosisError


def _registry(*effects: Effect) -> dict[str, Effect]:
    """Name -> effect in library order; a name given twice is a programming error."""
    registry: dict[str, Effect] = {}
    for effect in effects:
        if effect.name in registry:
            raise ValueError(f"two effects are named {effect.name!r}")
        registry[effect.name] = effect
    return registry


EFFECTS: dict[str, Effect] = _registry(
    SealFriction(), GasForce(), Hysteresis(), Backlash(), Inertia(), Temperature(), FrequencyDependence(),
    AmplitudeDependence(), SensorOffset(),
)


def select_effects(names: tuple[str, ...] | None) -> list[Effect]:
    """The effects named (None: all, in library order); an unknown name raises DiagnosisError listing the library."""
    if names is None:
        return list(EFFECTS.values())
    unknown = [name for name in names if name not in EFFECTS]
    if unknown:
        raise DiagnosisError(f"unknown effect(s) {', '.join(map(repr, unknown))}; the library has {', '.join(EFFECTS)}")
    return [EFFECTS[name] for name in names]


__all__ = ["EFFECTS", "Effect", "Extension", "NoExtension", "Regressors", "select_effects"]
