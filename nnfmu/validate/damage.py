"""Rainflow counting and Basquin pseudo-damage, the fatigue measure durability engineers compare loads by.

Pseudo-damage D = sum_i n_i * S_i^m (Miner's rule with an S-N curve N = C * S^-m, the constant C dropped): it is
only meaningful as a ratio between two signals of the same channel, which is how the report uses it.
"""

from __future__ import annotations

import numpy as np
import rainflow


def rainflow_cycles(signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rainflow cycles of `signal` (ASTM E1049) as (ranges, counts); a half cycle counts 0.5, ranges are unbinned."""
    cycles = rainflow.count_cycles(np.asarray(signal, dtype=float))
    if not cycles:
        return np.zeros(0), np.zeros(0)
    ranges, counts = zip(*cycles)
    return np.asarray(ranges, dtype=float), np.asarray(counts, dtype=float)


def pseudo_damage(signal: np.ndarray, slope: float) -> float:
    """Basquin pseudo-damage sum_i n_i * S_i^slope over the rainflow cycles of `signal`."""
    if not slope > 0:
        raise ValueError(f"Basquin slope must be positive, got {slope!r}")
    ranges, counts = rainflow_cycles(signal)
    return float(np.sum(counts * ranges**slope))


def pseudo_damage_ratio(result: np.ndarray, reference: np.ndarray, slope: float) -> float:
    """D(result) / D(reference) for Basquin slope `slope`; NaN when the reference has no cycles."""
    d_ref = pseudo_damage(reference, slope)
    return pseudo_damage(result, slope) / d_ref if d_ref > 0 else float("nan")
