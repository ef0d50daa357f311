"""The effect library: ONE registry of the physical effects a model may lack, each with both halves of the loop
(regressors for the diagnosis, a feature-spec extension for the retraining; see `base.Effect`), under a stable
name. Grouped by physical family, one module each."""

from __future__ import annotations

from ..errors import DiagnosisError
from .backlash import Backlash
from .base import Effect, Extension, NoExtension, Regressors
from .friction import SealFriction
from .gas_spring import GasForce
from .hysteresis import Hysteresis
from .inertia import Inertia
from .sensor import SensorOffset
from .temperature import Temperature
from .viscoelastic import AmplitudeDependence, FrequencyDependence


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
