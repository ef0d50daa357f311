"""Helpers shared by the effects: the running filters, delays and reversal bookkeeping their regressors and
extensions are built from."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from nnfmu.diagnosis.signals import EffectSignals

CENTRED = (
    "; centred on its record mean, so that only its variation counts as evidence (a constant level times the "
    "prediction is a plain gain error of the model, which no effect can be told from)"
)


def rms(x: np.ndarray) -> float:
    """Root mean square of `x`."""
    return float(np.sqrt(np.mean(np.square(x))))


def low_pass(x: np.ndarray, time_constant: float, dt: float, initial: float | None = None) -> np.ndarray:
    """First-order low-pass (exact discretisation of 1/(τs+1)), started in steady state at `initial` (default x[0])."""
    a = float(np.exp(-dt / time_constant))
    start = x[0] if initial is None else initial
    filtered, _ = lfilter([1 - a], [1, -a], x, zi=[a * start])
    return filtered


def delayed(x: np.ndarray, samples: int) -> np.ndarray:
    """x(t - samples·dt), holding the first value before the record starts."""
    samples = min(samples, len(x) - 1)
    return np.concatenate([np.full(samples, x[0]), x[:-samples]])


def derived_note(s: EffectSignals, base: str) -> str:
    """Words saying how the channel `base` was derived, when the rig did not measure it (else "")."""
    return f" ({base} derived: {s.derived[base]})" if base in s.derived else ""


def reversal_travel(v: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(direction ±1, travel [m] since the last reversal) of every sample. A reversal is a velocity sign change
    beyond ±2 % of the rms velocity, so noise about zero velocity does not flip the direction. Before the first
    reversal the travel is unknown and taken as infinite (no build-up is claimed at the record's start)."""
    threshold = 0.02 * rms(v)
    direction = np.empty_like(v)
    travel = np.empty_like(v)
    state, distance = (1.0 if v[0] >= 0 else -1.0), np.inf
    for i, value in enumerate(v):
        if value * state < -threshold:
            state, distance = -state, 0.0
        distance += abs(value) * dt
        direction[i], travel[i] = state, distance
    return direction, travel


def mean_stroke(v: np.ndarray, dt: float) -> float:
    """Mean travel [m] between motion reversals of the velocity `v` (the whole travel when it never reverses)."""
    direction, travel = reversal_travel(v, dt)
    ends = np.nonzero(np.diff(direction))[0]
    finite = travel[ends][np.isfinite(travel[ends])]
    return float(np.mean(finite)) if finite.size else float(np.sum(np.abs(v)) * dt)


def stop_operator(x: np.ndarray, radius: float) -> np.ndarray:
    """x minus its play-operator output at half-width `radius`, the driven side starting at x[0] - clipped to
    [-radius, radius]: where the driving side sits in a backlash gap (±radius: in contact)."""
    play = float(x[0])
    out = np.empty(len(x))
    for k, value in enumerate(np.asarray(x, dtype=float).tolist()):
        play = min(max(play, value - radius), value + radius)
        out[k] = value - play
    return out


def backlash_radii(v: np.ndarray, dt: float, fractions: tuple[float, ...]) -> tuple[float, ...]:
    """Half-widths [m] of the backlash gaps tried: each fraction of the mean travel between reversals is the travel
    over which that gap closes after a reversal (2 × radius)."""
    stroke = mean_stroke(v, dt)
    return tuple(0.5 * fraction * (stroke if stroke > 0 else 1.0) for fraction in fractions)
