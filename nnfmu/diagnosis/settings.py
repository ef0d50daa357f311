"""Settings of a residual diagnosis, checked once here."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import DiagnosisError


@dataclass(frozen=True)
class DiagnosisSettings:
    """What the diagnosis tests and how strictly.

    `alpha`: significance level of every residual test and of the effect ranking (family-wise over the effects,
    Bonferroni). `max_lag`: largest lag [samples] of the correlation tests. `blocks`: the record is cut into this
    many contiguous blocks; half of them fit, the other half evaluate, then the other way round (2-fold
    cross-fitting), so every explained variance is out of sample. `min_samples`: shorter records are refused.
    `effects`: names from the effect library to rank (None: all).
    Effect regressors: `lp_time_constants` [s], the low-pass time constants of the frequency-dependence states;
    `memory_delays` [s], the delays of the hysteresis family; `reversal_fractions`, its travel lengths after a motion
    reversal as fractions of the mean travel between reversals; `amplitude_window` [s], the averaging time of the
    running amplitude; `friction_scales`, the velocity scales of the smoothed sign as fractions of the rms velocity.
    """

    alpha: float = 0.05
    max_lag: int = 25
    blocks: int = 32
    min_samples: int = 1000
    effects: tuple[str, ...] | None = None
    lp_time_constants: tuple[float, ...] = (0.01, 0.1, 1.0)
    memory_delays: tuple[float, ...] = (0.002, 0.005, 0.02)
    reversal_fractions: tuple[float, ...] = (0.03, 0.1, 0.3)
    amplitude_window: float = 1.0
    friction_scales: tuple[float, ...] = (0.005, 0.02, 0.1)

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
        for name in ("lp_time_constants", "memory_delays", "reversal_fractions", "friction_scales"):
            values = getattr(self, name)
            if not values or not all(math.isfinite(v) and v > 0 for v in values):
                raise DiagnosisError(f"{name} must be a non-empty tuple of positive numbers, got {values!r}")
        if not (math.isfinite(self.amplitude_window) and self.amplitude_window > 0):
            raise DiagnosisError(f"amplitude_window must be a positive time [s], got {self.amplitude_window!r}")
