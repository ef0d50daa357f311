"""Sine tests found in a lab record: stretches where the position repeats whole cycles of one period and amplitude.

The rule (docs/characterise.md): upward crossings of the position through zero, counted with a hysteresis of
HYSTERESIS of the record's largest |position| so noise at rest or at a crossing counts none, cut the record into
cycles; consecutive cycles whose periods agree within PERIOD_TOLERANCE and whose half peak-to-peak amplitudes agree
within AMPLITUDE_TOLERANCE form a run; a run of at least MIN_CYCLES cycles whose first harmonic explains at least
MIN_R2 of the position's variance is a sine test. Ramps in and out of a level and random drive parts fail the
agreement or the fit and are left out. Downward crossings are tried as well, and a test they find with more cycles
replaces the upward crossings' there: a level ramped in and out over half a cycle each (as a rig starts and stops a
speed from rest) holds its whole-amplitude cycles between its downward crossings, so a level of 3 cycles has 2 there
and 1 between upward ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.workflows.characterise.analysis import first_harmonic

HYSTERESIS = 0.02
PERIOD_TOLERANCE = 0.02
AMPLITUDE_TOLERANCE = 0.05
MIN_CYCLES = 2
MIN_R2 = 0.99


@dataclass(frozen=True)
class SineSegment:
    """A sine test found in a record: samples [start, stop), frequency [Hz], amplitude (the position's unit),
    and its cycles (their crossing samples)."""

    start: int
    stop: int
    frequency: float
    amplitude: float
    cycles: int


def _crossings(position: np.ndarray, level: float) -> list[int]:
    """Sample indices where the position, having been below -level, first reaches >= 0 on its way above +level."""
    found, low, last_nonpositive = [], False, 0
    for i, x in enumerate(position):
        if x < -level:
            low = True
        if x <= 0:
            last_nonpositive = i
        elif low and x > level:
            found.append(last_nonpositive + 1)
            low = False
    return found


def _instant(time: np.ndarray, position: np.ndarray, i: int) -> float:
    """The time of the zero crossing between samples i-1 (<= 0) and i (> 0), linearly interpolated."""
    if i == 0:
        return float(time[0])
    x0, x1 = position[i - 1], position[i]
    return float(time[i - 1] + (time[i] - time[i - 1]) * (-x0) / (x1 - x0))


def _agree(a: float, b: float, tolerance: float) -> bool:
    return abs(a - b) <= tolerance * max(abs(a), abs(b))


def find_sine_tests(time: np.ndarray, position: np.ndarray) -> list[SineSegment]:
    """The sine tests of one position channel (module docstring), in time order."""
    position = np.asarray(position, dtype=float)
    reach = float(np.max(np.abs(position))) if position.size else 0.0
    if reach == 0:
        return []
    found = _segments(time, position, reach)
    for segment in _segments(time, -position, reach):  # the downward crossings'
        overlapping = [f for f in found if f.start < segment.stop and segment.start < f.stop]
        if all(segment.cycles > f.cycles for f in overlapping):
            found = [f for f in found if f not in overlapping] + [segment]
    return sorted(found, key=lambda f: f.start)


def _segments(time: np.ndarray, position: np.ndarray, reach: float) -> list[SineSegment]:
    """The sine tests between upward crossings of `position`, whose largest |value| is `reach`."""
    edges = _crossings(position, HYSTERESIS * reach)
    instants = [_instant(time, position, i) for i in edges]
    cycles = [
        (a, b, tb - ta, 0.5 * (position[a:b].max() - position[a:b].min()))
        for a, b, ta, tb in zip(edges, edges[1:], instants, instants[1:])
    ]
    runs: list[list[tuple]] = []
    for cycle in cycles:
        last = runs[-1][-1] if runs else None
        if (
            last is not None
            and last[1] == cycle[0]
            and _agree(last[2], cycle[2], PERIOD_TOLERANCE)
            and _agree(last[3], cycle[3], AMPLITUDE_TOLERANCE)
        ):
            runs[-1].append(cycle)
        else:
            runs.append([cycle])
    segments = []
    for run in runs:
        if len(run) < MIN_CYCLES:
            continue
        start, stop = run[0][0], run[-1][1]
        frequency = 1.0 / float(np.mean([c[2] for c in run]))
        t, x = time[start:stop], position[start:stop]
        fit = first_harmonic(t, x, frequency)
        model = fit.mean + np.imag(fit.phasor * np.exp(2j * np.pi * frequency * t))
        variance = float(np.var(x))
        if variance == 0 or 1 - float(np.mean((x - model) ** 2)) / variance < MIN_R2:
            continue
        segments.append(SineSegment(start, stop, frequency, fit.amplitude, len(run)))
    return segments
