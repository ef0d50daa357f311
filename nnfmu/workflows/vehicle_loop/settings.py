"""Settings of `nnfmu loop vehicle`, checked once here, and its exception."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from nnfmu.cosim import DEFAULT_STEP
from nnfmu.errors import NnfmuError
from nnfmu.fmu import fmu_sample_period
from nnfmu.workflows.loop import LoopSettings


class VehicleLoopError(NnfmuError, ValueError):
    """The vehicle loop cannot run on this record, drive or system; the message names the file, element or channel."""


def _in_situ_loop() -> LoopSettings:
    """The component loop run on a damper's in-situ record: one effect at a time, a shorter retraining than a dyno
    record's (the vehicle record is shorter and the fix is checked again in the vehicle)."""
    return LoopSettings(max_effects=2, max_epochs=300, extra_hidden=(0, 6), fresh_rival=False)


@dataclass(frozen=True)
class VehicleLoopSettings:
    """How the vehicle loop replays, attributes and fixes.

    `step` [s]: the co-simulation's communication step (None: the vehicle FMU's sample period, as the road test
    built it; `DEFAULT_STEP` for a vehicle that carries none). `settle` [s]: the first seconds of the record left out of
    every metric and fit (the virtual car starts at rest on its networks, the lab car on its own physics; after a fix
    the virtual car settles to its new rest state). `blocks`: the record is cut into this many contiguous blocks,
    half fit and half evaluate, then the other way round (out of sample, as the component diagnosis does).
    `alpha`: family-wise significance (Bonferroni over the candidates). `min_explained`: a candidate is added only
    when it explains at least this fraction of the residual left by those added before. `max_effects`: most
    (component, effect) pairs and sensor offsets named. `in_situ`: the component loop's settings on a damper's
    in-situ record (damper force and displacement measured). `budget`: the largest NRMSE [1] a channel may keep for
    an unexplained residual to be called consistent with the co-simulation error budget (the networks' own error and
    the coupling stay within a few per cent on the road test). `allow_outside`: the system's FMUs may lie outside its
    folder (`open_system`)."""

    step: float | None = None
    settle: float = 1.5
    blocks: int = 16
    alpha: float = 0.05
    min_explained: float = 0.05
    max_effects: int = 3
    budget: float = 0.25
    in_situ: LoopSettings = field(default_factory=_in_situ_loop)
    allow_outside: bool = False

    def __post_init__(self) -> None:
        if self.step is not None and not (math.isfinite(self.step) and self.step > 0):
            raise VehicleLoopError(f"step {self.step!r} s must be a positive number")

    def step_for(self, vehicle_fmu: Path) -> float:
        """The communication step [s] for a virtual car with this vehicle FMU: `step`, else the FMU's sample period
        (the finest step its feedthrough allows), else `DEFAULT_STEP`."""
        if self.step is not None:
            return self.step
        return fmu_sample_period(vehicle_fmu) or DEFAULT_STEP
        if not (math.isfinite(self.settle) and self.settle >= 0):
            raise VehicleLoopError(f"settle {self.settle!r} s must be a number >= 0")
        if self.blocks < 2 or self.blocks % 2:
            raise VehicleLoopError(f"blocks must be an even number >= 2, got {self.blocks!r}")
        if not (0 < self.alpha < 1 and 0 <= self.min_explained < 1):
            raise VehicleLoopError(
                f"alpha must lie in (0, 1) and min_explained in [0, 1), got {self.alpha!r}, {self.min_explained!r}"
            )
        if not (math.isfinite(self.budget) and 0 < self.budget < 1):
            raise VehicleLoopError(f"budget {self.budget!r} (an NRMSE) must lie in (0, 1)")
        if isinstance(self.max_effects, bool) or not isinstance(self.max_effects, int) or self.max_effects < 0:
            raise VehicleLoopError(f"max_effects must be an integer >= 0, got {self.max_effects!r}")
