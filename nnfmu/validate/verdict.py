"""One line per report: the error it measured against the target it was run for, and where that target comes from
(an option the user gave, or nnfmu's default), e.g. "damper force NRMSE 1.8 % — within the 5 % target (default)"."""

from __future__ import annotations

import math
from dataclasses import dataclass

from nnfmu.validate.compare import ValidationError

# The NRMSE a component model is held to unless the user names another: a load model within 5 % RMS of its reference
# is what a durability engineer accepts for a component (nnfmu's damper networks reach 1.6-2 % on their rig records,
# README walk and loop demo), and twice the error of a good fit still passes.
DEFAULT_TARGET_NRMSE = 0.05
DEFAULT_SOURCE = "default"


@dataclass(frozen=True)
class Target:
    """The largest NRMSE [1] a result may have to pass, and where it comes from (DEFAULT_SOURCE or the option)."""

    nrmse: float = DEFAULT_TARGET_NRMSE
    source: str = DEFAULT_SOURCE

    def __post_init__(self) -> None:
        if isinstance(self.nrmse, bool) or not (isinstance(self.nrmse, (int, float)) and 0 < self.nrmse <= 10):
            raise ValidationError(f"target NRMSE must be a fraction in (0, 10] (0.05 = 5 %), got {self.nrmse!r}")

    @property
    def words(self) -> str:
        return f"the {percent(self.nrmse)} target ({self.source})"


def percent(fraction: float) -> str:
    """`0.018` -> `1.8 %`, three significant digits at most."""
    return f"{100 * fraction:.3g} %"


def verdict(what: str, nrmse: float | None, target: Target, before: float | None = None, where: str = "") -> str:
    """`what` NRMSE (`where`, e.g. " on the test part") against `target` in one line; with `before`, the error
    before -> after."""
    if nrmse is None or not math.isfinite(nrmse):
        return f"{what}: no NRMSE to judge (the reference has no RMS), no verdict against {target.words}"
    error = percent(nrmse) if before is None or not math.isfinite(before) else f"{percent(before)} → {percent(nrmse)}"
    return f"{what} NRMSE{where} {error} — {'within' if nrmse <= target.nrmse else 'above'} {target.words}"
