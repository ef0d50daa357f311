"""Drive signals of an iteration: the fade from and back to rest, post rates, band-limited noise, band filtering."""

from __future__ import annotations

import numpy as np
from scipy.fft import irfft, next_fast_len, rfft, rfftfreq

from nnfmu.workflows.iterate.settings import ActuatorLimits


def fade_weights(n: int, dt: float, fade: float) -> np.ndarray:
    """Weights (n,) rising from 0 to 1 over `fade` [s] and falling back to 0 over the last `fade` [s] (raised
    cosines: value and slope 0 at both ends, so a faded drive starts and ends with its post at rest)."""
    t = np.arange(n) * dt
    ramp = np.clip(np.minimum(t, t[-1] - t) / fade, 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * ramp))


def rates(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of displacements `x` (n, m) sampled every `dt` [s] (central differences)."""
    v = np.gradient(x, dt, axis=0)
    return v, np.gradient(v, dt, axis=0)


def limit_ratios(x: np.ndarray, dt: float, limits: ActuatorLimits) -> dict[str, float]:
    """Peak stroke, velocity and acceleration of drive `x` (n, m) as fractions of their limits (> 1: exceeded)."""
    v, a = rates(x, dt)
    return {
        "stroke": float(np.max(np.abs(x))) / limits.stroke,
        "velocity": float(np.max(np.abs(v))) / limits.velocity,
        "acceleration": float(np.max(np.abs(a))) / limits.acceleration,
    }


def within(x: np.ndarray, dt: float, limits: ActuatorLimits) -> bool:
    return max(limit_ratios(x, dt, limits).values()) <= 1.0


def largest_step(base: np.ndarray, delta: np.ndarray, dt: float, limits: ActuatorLimits) -> float:
    """The largest s in [0, 1] with base + s·delta within `limits`, `base` being within them (each peak is a convex
    function of s, so the allowed s form an interval from 0: bisection to 1e-6)."""
    if within(base + delta, dt, limits):
        return 1.0
    low, high = 0.0, 1.0
    while high - low > 1e-6:
        middle = 0.5 * (low + high)
        low, high = (middle, high) if within(base + middle * delta, dt, limits) else (low, middle)
    return low


def band_noise(n: int, dt: float, band: tuple[float, float], rms_velocity: float, count: int, seed: int) -> np.ndarray:
    """`count` independent displacement noises (n, count) [m] with a flat velocity spectrum over `band` [Hz] (random
    phases), each scaled to RMS velocity `rms_velocity` [m/s]."""
    rng = np.random.default_rng(seed)
    f = rfftfreq(n, dt)
    inside = (f >= band[0]) & (f <= band[1])
    spectrum = np.zeros((len(f), count), dtype=complex)
    phases = rng.uniform(0.0, 2.0 * np.pi, size=(int(inside.sum()), count))
    spectrum[inside] = np.exp(1j * phases) / (2.0 * np.pi * f[inside, None])
    x = irfft(spectrum, n, axis=0)
    v, _ = rates(x, dt)
    return x * (rms_velocity / np.sqrt(np.mean(v**2, axis=0)))


def band_filter(x: np.ndarray, dt: float, band: tuple[float, float]) -> np.ndarray:
    """`x` (n, ...) with every frequency outside `band` [Hz] removed (FFT over a zero-padded record)."""
    n = x.shape[0]
    size = next_fast_len(2 * n)
    f = rfftfreq(size, dt)
    spectrum = rfft(x, size, axis=0)
    spectrum[(f < band[0]) | (f > band[1])] = 0.0
    return irfft(spectrum, size, axis=0)[:n]
