"""Rainflow counting and Basquin pseudo-damage, the fatigue measure durability engineers compare loads by.

Pseudo-damage D = sum_i n_i * S_i^m (Miner's rule with an S-N curve N = C * S^-m, the constant C dropped): it is
only meaningful as a ratio between two signals of the same channel, which is how the report uses it.
"""

from __future__ import annotations

import math

import numpy as np
import rainflow

from nnfmu.errors import NnfmuError

MAX_SLOPE = 50.0  # largest Basquin slope m accepted: S-N exponents of metals and elastomers lie in 3 to 20


class DamageError(NnfmuError, ValueError):
    """A Basquin slope out of its range, or a pseudo-damage too large for a float; the message names the value."""


def check_slope(slope: float, what: str = "Basquin slope") -> float:
    """`slope` as a float if it lies in (0, MAX_SLOPE], else a `DamageError` naming `what` and the value."""
    if isinstance(slope, bool) or not isinstance(slope, (int, float)) or not 0 < slope <= MAX_SLOPE:
        raise DamageError(f"{what} = {slope!r} must be a number in (0, {MAX_SLOPE:g}]")
    return float(slope)


def rainflow_cycles(signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rainflow cycles of `signal` (ASTM E1049) as (ranges, counts); a half cycle counts 0.5, ranges are unbinned."""
    cycles = rainflow.count_cycles(np.asarray(signal, dtype=float))
    if not cycles:
        return np.zeros(0), np.zeros(0)
    ranges, counts = zip(*cycles)
    return np.asarray(ranges, dtype=float), np.asarray(counts, dtype=float)


def pseudo_damage(signal: np.ndarray, slope: float) -> float:
    """Basquin pseudo-damage sum_i n_i * S_i^slope over the rainflow cycles of `signal`; a `DamageError` when the
    slope is out of range or the sum is too large for a float (never an infinite damage)."""
    slope = check_slope(slope)
    ranges, counts = rainflow_cycles(signal)
    with np.errstate(over="ignore", invalid="ignore"):
        damage = float(np.sum(counts * ranges**slope))
    if not math.isfinite(damage):
        raise DamageError(
            f"pseudo-damage with Basquin slope {slope:g} is too large for a float (largest rainflow range "
            f"{float(np.max(ranges)):.6g}, raised to {slope:g}); choose a smaller slope or a smaller unit"
        )
    return damage


def pseudo_damage_ratio(result: np.ndarray, reference: np.ndarray, slope: float) -> float:
    """D(result) / D(reference) for Basquin slope `slope`; NaN when the reference has no cycles."""
    d_ref = pseudo_damage(reference, slope)
    return pseudo_damage(result, slope) / d_ref if d_ref > 0 else float("nan")
