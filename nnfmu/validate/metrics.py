"""Scalar error metrics comparing a result signal with its reference, as a durability engineer reads them.

All functions take two 1-D arrays of the same length on the same time base (`result`, `reference`) in SI units.
A metric whose denominator is zero (e.g. NRMSE of an all-zero reference) is NaN rather than an exception, so one
degenerate channel never hides the others; `summary.json` writes NaN as null.
"""

from __future__ import annotations

import numpy as np

DEFINITIONS: dict[str, str] = {
    "nrmse": "RMS(result - reference) / RMS(reference); RMS(x) = sqrt(mean(x^2)), the mean is not removed [1]",
    "r2": "1 - sum((reference - result)^2) / sum((reference - mean(reference))^2) [1]",
    "peak_ratio": "max(result) / max(reference) [1]",
    "valley_ratio": "min(result) / min(reference) [1]",
    "mean_shift": "mean(result) - mean(reference) [channel unit]",
    "rms_ratio": "RMS(result) / RMS(reference), the mean included [1]",
    "peak_error": "(max|result| - max|reference|) / max|reference|, signed [1]",
    "pseudo_damage_ratio": (
        "D(result) / D(reference), D = sum_i n_i * S_i^m over rainflow cycles (range S_i, count n_i, half cycles "
        "count 0.5), m = Basquin slope of the channel [1]"
    ),
}


def _ratio(numerator: float, denominator: float) -> float:
    return float(numerator / denominator) if denominator != 0 else float("nan")


def rms(x: np.ndarray) -> float:
    """Root mean square sqrt(mean(x^2)), the mean included."""
    return float(np.sqrt(np.mean(np.square(x))))


def nrmse(result: np.ndarray, reference: np.ndarray) -> float:
    """RMS error normalised by the RMS of the reference: 0 for a perfect match, 1 for a result that is all zero."""
    return _ratio(rms(result - reference), rms(reference))


def r2(result: np.ndarray, reference: np.ndarray) -> float:
    """Coefficient of determination of `result` as a prediction of `reference` (1 perfect, may be negative)."""
    ss_res = float(np.sum(np.square(reference - result)))
    ss_tot = float(np.sum(np.square(reference - np.mean(reference))))
    return 1.0 - _ratio(ss_res, ss_tot)


def peak_ratio(result: np.ndarray, reference: np.ndarray) -> float:
    """Ratio of the largest (most positive) values."""
    return _ratio(float(np.max(result)), float(np.max(reference)))


def valley_ratio(result: np.ndarray, reference: np.ndarray) -> float:
    """Ratio of the smallest (most negative) values."""
    return _ratio(float(np.min(result)), float(np.min(reference)))


def mean_shift(result: np.ndarray, reference: np.ndarray) -> float:
    """Difference of the means, in the channel's unit (the 0 Hz offset the thesis saw between models)."""
    return float(np.mean(result) - np.mean(reference))


def rms_ratio(result: np.ndarray, reference: np.ndarray) -> float:
    """Ratio of the RMS values, the mean included."""
    return _ratio(rms(result), rms(reference))


def peak_error(result: np.ndarray, reference: np.ndarray) -> float:
    """Signed relative error of the absolute peak: +0.1 means the result's largest magnitude is 10 % too high."""
    peak_ref = float(np.max(np.abs(reference)))
    return _ratio(float(np.max(np.abs(result))) - peak_ref, peak_ref)
