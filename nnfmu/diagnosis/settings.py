"""Settings of a residual diagnosis and of the effects it ranks and extends models with, checked once here."""

from __future__ import annotations

import math
from dataclasses import dataclass

from nnfmu.diagnosis.errors import DiagnosisError

# DiagnosisSettings fields that tune how the residual is tested; every other field is an effect parameter, read by
# the effect(s) that name it in `Effect.parameters` (tests/diagnosis/test_registry.py checks each has an owner).
TEST_FIELDS = ("alpha", "max_lag", "blocks", "min_samples", "effects")


@dataclass(frozen=True)
class DiagnosisSettings:
    """What the diagnosis tests and how strictly, and the parameters of the effect library.

    `alpha`: significance level of every residual test and of the effect ranking (family-wise over the effects,
    Bonferroni). `max_lag`: largest lag [samples] of the correlation tests. `blocks`: the record is cut into this
    many contiguous blocks; half of them fit, the other half evaluate, then the other way round (2-fold
    cross-fitting), so every explained variance is out of sample. `min_samples`: shorter records are refused.
    `effects`: names from the effect library or `input:<channel>` candidates to rank (None: all of both).

    Effect parameters, each named once and read by both halves of its effect (the diagnosis's regressors and the
    model extension). Where the diagnosis tries several values and the extension adds fewer, the extension picks
    from the same tuple by a fixed rule:
    `friction_scales` (seal_friction): velocity scales of the smoothed sign as fractions of the rms velocity; the
    diagnosis tries each, the extension adds the middle one (of the sorted scales). `memory_times` [s]
    (hysteresis): the diagnosis delays the model's force by each; the extension adds low-pass states of velocity at
    the shortest and the longest. `reversal_fractions` (hysteresis, backlash, presliding_friction): travel
    lengths after a motion reversal as fractions of the mean travel between reversals; both halves use each (the
    stop reading also bins the travel after reversals by half the smallest, up to the largest). `frequency_taus` [s]
    (frequency_dependence): low-pass time constants of the viscoelastic states; both halves use each.
    `amplitude_tau` [s] (amplitude_dependence): averaging time of the running amplitude. `thermal_tau` [s]
    (temperature, extension only): thermal time constant of the running mean square of velocity that stands in for
    an unmeasured temperature. `channel_taus` [s] (every `input:<channel>` candidate, a measured channel the model
    does not use): time constants of the channel's low-passes; both halves use each (a command acts through the lag
    of a coil or valve, ~1-30 ms).
    """

    alpha: float = 0.05
    max_lag: int = 25
    blocks: int = 32
    min_samples: int = 1000
    effects: tuple[str, ...] | None = None
    friction_scales: tuple[float, ...] = (0.005, 0.02, 0.1)
    memory_times: tuple[float, ...] = (0.002, 0.005, 0.02)
    reversal_fractions: tuple[float, ...] = (0.03, 0.1, 0.3)
    frequency_taus: tuple[float, ...] = (0.01, 0.1, 1.0)
    amplitude_tau: float = 1.0
    thermal_tau: float = 300.0
    channel_taus: tuple[float, ...] = (0.005, 0.02, 0.1)

    def __post_init__(self) -> None:
        if not (0 < self.alpha < 1):
            raise DiagnosisError(f"alpha must lie in (0, 1), got {self.alpha!r}")
        if self.max_lag < 1:
            raise DiagnosisError(f"max_lag must be at least 1 sample, got {self.max_lag!r}")
        if self.blocks < 2 or self.blocks % 2:
            raise DiagnosisError(f"blocks must be an even number >= 2 (half fit, half evaluate), got {self.blocks}")
        if self.min_samples < 20 * self.max_lag or self.min_samples < 16 * self.blocks:
            raise DiagnosisError(
                f"min_samples {self.min_samples} is too small: at least 20*max_lag ({20 * self.max_lag}) and "
                f"16*blocks ({16 * self.blocks}) are needed for the tests to mean anything"
            )
        for name in ("friction_scales", "memory_times", "reversal_fractions", "frequency_taus", "channel_taus"):
            values = getattr(self, name)
            if not values or not all(math.isfinite(v) and v > 0 for v in values):
                raise DiagnosisError(f"{name} must be a non-empty tuple of positive numbers, got {values!r}")
        for name in ("amplitude_tau", "thermal_tau"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise DiagnosisError(f"{name} must be a positive time [s], got {value!r}")
