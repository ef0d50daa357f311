"""The effect contract: each physical effect a model may lack provides, under one stable name, both halves of the
loop: the candidate regressors the diagnosis ranks against the residual (`Effect.regressors`) and the extension of
the model's feature spec that lets a retrained network take the effect in (`Effect.extension`), or an explicit
`NoExtension` saying why there is none. Both halves read the effect's parameters from the same `DiagnosisSettings`
fields, which the effect names in `parameters`.

Extensions add input channels, delays or derived states inside the step graph, each computable sample by sample
from the component's inputs; channel names carry the output's direction prefix (`axial_force` ->
`axial_displacement`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from nnfmu.data import Measurement
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals, direction_prefix
from nnfmu.models.features import Derived, FeatureSpec, Tap


@dataclass(frozen=True)
class Regressors:
    """Columns of one effect, shape (n, k), their names, the channels a direct measurement would need, and how."""

    names: tuple[str, ...]
    matrix: np.ndarray
    missing: tuple[str, ...]
    note: str


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


class Effect(ABC):
    """One physical effect: its name, what it is, the base channels its regressors need (`requires`; rates the rig
    did not measure are derived first), the `DiagnosisSettings` fields it reads (`parameters`), its regressors and
    its model extension."""

    name: ClassVar[str]
    description: ClassVar[str]
    requires: ClassVar[tuple[str, ...]]
    parameters: ClassVar[tuple[str, ...]] = ()

    def missing(self, signals: EffectSignals) -> tuple[str, ...]:
        """The required base channels that `signals` lacks (the effect cannot be tested without them)."""
        return tuple(name for name in self.requires if not signals.has(name))

    @abstractmethod
    def regressors(self, signals: EffectSignals, settings: DiagnosisSettings) -> Regressors:
        """The candidate regressors the diagnosis ranks against the residual."""

    @abstractmethod
    def extension(
        self, spec: FeatureSpec, measurement: Measurement, fit_rows: np.ndarray, settings: DiagnosisSettings
    ) -> Extension | NoExtension:
        """The extension of `spec` for this effect, or why there is none. `fit_rows` (indices of `measurement`):
        the samples a scale may be taken from (the network will be fitted on them)."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


def channel(spec: FeatureSpec, base: str) -> str:
    """The channel of quantity `base` in the direction of `spec`'s output (`axial_force`, velocity ->
    `axial_velocity`)."""
    return direction_prefix(spec.output) + base


def need(effect: str, name: str, measurement: Measurement) -> NoExtension | None:
    """None when `measurement` has the channel `name`, else why `effect` cannot be added without it."""
    if name in measurement:
        return None
    return NoExtension(
        effect,
        f"{effect} needs the measured channel {name!r} as a model input; the data have {', '.join(measurement.names)}",
        (name,),
    )


def with_delays(spec: FeatureSpec, name: str, delays: tuple[int, ...]) -> FeatureSpec:
    """`spec` with channel `name` tapped at `delays` as well (a new tap goes after the existing ones)."""
    taps = list(spec.taps)
    for i, tap in enumerate(taps):
        if tap.channel == name:
            taps[i] = Tap(name, tuple(sorted(set(tap.delays) | set(delays))))
            break
    else:
        taps.append(Tap(name, tuple(delays)))
    return replace(spec, taps=tuple(taps))


def with_derived(spec: FeatureSpec, derived: tuple[Derived, ...]) -> FeatureSpec:
    """`spec` with the derived features it does not have yet appended."""
    known = {d.name for d in spec.derived}
    fresh = tuple(d for d in derived if d.name not in known)
    return replace(spec, derived=spec.derived + fresh)


def extended(effect: str, old: FeatureSpec, new: FeatureSpec, note: str) -> Extension | NoExtension:
    """The extension from `old` to `new`, or NoExtension when `new` adds no feature `old` lacks."""
    added = tuple(name for name in new.feature_names if name not in old.feature_names)
    if not added:
        return NoExtension(
            effect,
            f"the model already has the features for {effect} ({note}); a larger network or "
            f"more data may be needed instead",
        )
    return Extension(effect, new, added, note)
