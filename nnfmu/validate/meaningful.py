"""When a record is too short for a metric: the one rule per metric every report applies, so a 0.3 s smoke run shows
"not meaningful (record too short)" instead of a number read from one or two cycles.

- An amplitude (PSD) ratio at a frequency f needs the record to span at least MIN_PERIODS periods of f and its
  spectrum to have a line at or below f (a 0.3 s record's first Welch line lies at 3.3 Hz; at 1 Hz: 4 s).
- A rainflow pseudo-damage ratio needs the reference to hold at least MIN_DAMAGE_CYCLES cycles (half cycles count
  0.5) whose range is at least DAMAGE_RANGE_SHARE of its largest: with Basquin slopes of 3 to 20 the smaller ones carry
  under 2 % of the damage each, so with fewer the ratio is a ratio of one or two peaks raised to the slope, not a
  fatigue statement (the quick demo's 0.3 s full vehicle: 0.5 to 9.5 such cycles per channel; a 50 s drive: hundreds).
"""

from __future__ import annotations

import numpy as np

from nnfmu.validate.damage import rainflow_cycles

NOT_MEANINGFUL = "not meaningful (record too short)"
MIN_PERIODS = 4  # periods of a frequency a record must span for an amplitude ratio read there
MIN_DAMAGE_CYCLES = 10.0  # reference rainflow cycles carrying the damage that a damage ratio needs
DAMAGE_RANGE_SHARE = 0.25  # a cycle carries damage when its range is at least this share of the largest


def damage_cycles(reference: np.ndarray) -> float:
    """Rainflow cycles of `reference` (half cycles 0.5) with a range of at least DAMAGE_RANGE_SHARE of its largest."""
    ranges, counts = rainflow_cycles(reference)
    if ranges.size == 0:
        return 0.0
    return float(np.sum(counts[ranges >= DAMAGE_RANGE_SHARE * np.max(ranges)]))


def damage_reason(reference: np.ndarray) -> str | None:
    """None when a pseudo-damage ratio against `reference` means something, else why not (NOT_MEANINGFUL first)."""
    cycles = damage_cycles(reference)
    if cycles >= MIN_DAMAGE_CYCLES:
        return None
    return (
        f"{NOT_MEANINGFUL}: the reference holds {cycles:g} rainflow cycles of at least {DAMAGE_RANGE_SHARE:.0%} of its "
        f"largest range, {MIN_DAMAGE_CYCLES:g} needed"
    )


def frequency_reason(duration: float, lines: np.ndarray, frequency: float) -> str | None:
    """None when a record of `duration` [s] whose spectrum has the lines `lines` [Hz] resolves `frequency` [Hz], else
    why not (NOT_MEANINGFUL first)."""
    periods = duration * frequency
    if periods >= MIN_PERIODS and len(lines) >= 2 and lines[1] <= frequency:
        return None
    return f"{NOT_MEANINGFUL}: {duration:.3g} s hold {periods:.2g} periods of {frequency:g} Hz, {MIN_PERIODS} needed"
