"""All metrics of one channel in one object, computed from two aligned arrays (the closing-the-loop stage reuses it)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from nnfmu.validate import damage, metrics
from nnfmu.validate.meaningful import damage_reason


@dataclass(frozen=True)
class ChannelMetrics:
    """Every metric of `metrics.DEFINITIONS` for one channel, plus both pseudo-damages [unit^m] behind the ratio;
    `not_meaningful`: metric name -> why the record is too short for it (its value is then NaN, `meaningful.py`)."""

    nrmse: float
    r2: float
    peak_ratio: float
    valley_ratio: float
    mean_shift: float
    rms_ratio: float
    peak_error: float
    pseudo_damage_ratio: float
    pseudo_damage_result: float
    pseudo_damage_reference: float
    not_meaningful: dict[str, str] = field(default_factory=dict)

    def error_summary(self) -> dict[str, float]:
        """The four numbers that summarise a model error: nrmse, r2, peak_error, pseudo_damage_ratio."""
        return {
            "nrmse": self.nrmse,
            "r2": self.r2,
            "peak_error": self.peak_error,
            "pseudo_damage_ratio": self.pseudo_damage_ratio,
        }

    def to_dict(self) -> dict[str, float | None | dict[str, str]]:
        """JSON-safe dict: NaN and infinities become None; `not_meaningful` says why a metric is None for a short
        record."""
        values: dict[str, float | None | dict[str, str]] = {
            k: json_float(v) for k, v in asdict(self).items() if k != "not_meaningful"
        }
        values["not_meaningful"] = dict(self.not_meaningful)
        return values


def json_float(value: float) -> float | None:
    """`value` as a float JSON can hold, None where it is NaN or infinite."""
    value = float(value)
    return value if math.isfinite(value) else None


def channel_metrics(result: np.ndarray, reference: np.ndarray, slope: float) -> ChannelMetrics:
    """Compare two arrays of the same shape (n,) on the same time base; `slope` is the Basquin exponent m."""
    result = np.asarray(result, dtype=float)
    reference = np.asarray(reference, dtype=float)
    if result.shape != reference.shape or result.ndim != 1 or len(result) < 2:
        raise ValueError(f"need two 1-D arrays of equal length >= 2, got shapes {result.shape} and {reference.shape}")
    d_result = damage.pseudo_damage(result, slope)
    d_reference = damage.pseudo_damage(reference, slope)
    too_short = damage_reason(reference)
    return ChannelMetrics(
        nrmse=metrics.nrmse(result, reference),
        r2=metrics.r2(result, reference),
        peak_ratio=metrics.peak_ratio(result, reference),
        valley_ratio=metrics.valley_ratio(result, reference),
        mean_shift=metrics.mean_shift(result, reference),
        rms_ratio=metrics.rms_ratio(result, reference),
        peak_error=metrics.peak_error(result, reference),
        pseudo_damage_ratio=d_result / d_reference if d_reference > 0 and too_short is None else float("nan"),
        pseudo_damage_result=d_result,
        pseudo_damage_reference=d_reference,
        not_meaningful={"pseudo_damage_ratio": too_short} if too_short else {},
    )
