"""Lab-like prescribed motions: sine series with smooth ramps, and random signals whose PSD follows a target shape.

Every motion comes with its exact rate and acceleration (analytic for sines, spectral derivatives for random
signals), so the rig simulators need no numerical differentiation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from nnfmu.errors import SettingsError

RAMP_CYCLES = 0.5  # raised-cosine amplitude ramp at each end of a sine level, in cycles
MIN_SINE_CYCLES = 3  # cycles per sine level; with the ramps at least two full-amplitude cycles remain


@dataclass(frozen=True)
class Motion:
    """A prescribed motion on a uniform grid: position `x`, rate `v`, acceleration `a` (each shape (n,))."""

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray

    def __len__(self) -> int:
        return len(self.x)

    @staticmethod
    def rest(n: int) -> "Motion":
        return Motion(np.zeros(n), np.zeros(n), np.zeros(n))

    @staticmethod
    def concatenate(parts: list["Motion"]) -> "Motion":
        return Motion(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("x", "v", "a")))

    def fit(self, n: int) -> "Motion":
        """The first `n` samples, padded at rest where the motion is shorter."""
        pad = Motion.rest(max(0, n - len(self)))
        return Motion(*(np.concatenate([getattr(self, k)[:n], getattr(pad, k)]) for k in ("x", "v", "a")))

    def scaled(self, factor: float) -> "Motion":
        return Motion(self.x * factor, self.v * factor, self.a * factor)


class Spectrum(Protocol):
    """A target one-sided PSD of a position signal (relative: `random_motion` scales to unit rms)."""

    def psd(self, f: np.ndarray) -> np.ndarray:
        """PSD at frequencies `f` [Hz], zero outside the band."""
        ...

    def describe(self) -> dict:
        """Plain-JSON description for the truth file."""
        ...


@dataclass(frozen=True)
class SpectrumShape:
    """Target one-sided PSD shape of a position signal: flat from `f_low` to `f_corner` [Hz], then falling as
    (f_corner/f)^`slope` up to `f_high` [Hz], zero outside. Slope 2 makes the rate's spectrum flat above the corner."""

    f_low: float
    f_corner: float
    f_high: float
    slope: float

    def psd(self, f: np.ndarray) -> np.ndarray:
        """Relative PSD (peak 1) at frequencies `f` [Hz]."""
        f = np.asarray(f, dtype=float)
        inside = (f >= self.f_low) & (f <= self.f_high)
        falling = (self.f_corner / np.maximum(f, self.f_corner)) ** self.slope
        return np.where(inside, falling, 0.0)

    def describe(self) -> dict[str, float]:
        return {"f_low_Hz": self.f_low, "f_corner_Hz": self.f_corner, "f_high_Hz": self.f_high, "slope": self.slope}


@dataclass(frozen=True)
class SineLevel:
    """One level of a sine series: `amplitude` (SI unit of the position) at `frequency` [Hz]."""

    amplitude: float
    frequency: float


def _ramp(t: np.ndarray, length: float, total: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raised-cosine window rising over `length` s and falling over the last `length` s of `total`: w, w', w''."""
    w, dw, ddw = np.ones_like(t), np.zeros_like(t), np.zeros_like(t)
    k = math.pi / length
    for mask, tau, sign in ((t < length, t, 1.0), (t > total - length, total - t, -1.0)):
        w[mask] = 0.5 * (1 - np.cos(k * tau[mask]))
        dw[mask] = sign * 0.5 * k * np.sin(k * tau[mask])
        ddw[mask] = 0.5 * k * k * np.cos(k * tau[mask])
    return w, dw, ddw


def sine_level(level: SineLevel, cycles: int, rate: float) -> Motion:
    """`cycles` periods of A·w(t)·sin(2πft) sampled at `rate` [Hz], w ramping over RAMP_CYCLES at each end."""
    total = cycles / level.frequency
    t = np.arange(int(round(total * rate))) / rate
    w, dw, ddw = _ramp(t, RAMP_CYCLES / level.frequency, total)
    omega = 2 * math.pi * level.frequency
    s, c = np.sin(omega * t), np.cos(omega * t)
    amp = level.amplitude
    return Motion(amp * w * s, amp * (dw * s + w * omega * c), amp * (ddw * s + 2 * dw * omega * c - w * omega**2 * s))


def sine_series_cycles(levels: list[SineLevel], budget: float, rest: float) -> int:
    """The most cycles per level (at least MIN_SINE_CYCLES) for which the series with rests fits `budget` [s]."""
    per_cycle = sum(1 / lv.frequency for lv in levels)
    cycles = int((budget - rest * len(levels)) / per_cycle)
    if cycles < MIN_SINE_CYCLES:
        needed = MIN_SINE_CYCLES * per_cycle + rest * len(levels)
        raise SettingsError(f"the sine series needs at least {needed:.3g} s, only {budget:.3g} s are available for it")
    return cycles


def sine_series(levels: list[SineLevel], cycles: int, rate: float, rest: float) -> tuple[Motion, list[dict]]:
    """Each level for `cycles` periods followed by `rest` s at rest; returns the motion and a per-level description."""
    parts: list[Motion] = []
    described: list[dict] = []
    start = 0
    for level in levels:
        part = sine_level(level, cycles, rate)
        described.append(
            {
                "amplitude": level.amplitude,
                "frequency_Hz": level.frequency,
                "peak_rate": 2 * math.pi * level.frequency * level.amplitude,
                "cycles": cycles,
                "start_s": start / rate,
                "end_s": (start + len(part)) / rate,
            }
        )
        parts += [part, Motion.rest(int(round(rest * rate)))]
        start += len(part) + len(parts[-1])
    return Motion.concatenate(parts), described


def preload(level: float, rate: float, n: int, fade: float) -> Motion:
    """A constant `level` held over `n` samples at `rate` [Hz], raised-cosine faded in and out over `fade` s, so a
    drive around a working point starts and ends at rest."""
    t = np.arange(n) / rate
    w, dw, ddw = _ramp(t, fade, n / rate)
    return Motion(level * w, level * dw, level * ddw)


def random_motion(shape: Spectrum, rate: float, n: int, rng: np.random.Generator, fade: float) -> Motion:
    """Random motion of `n` samples at `rate` [Hz] whose PSD follows `shape` (unit rms before the fade).

    A random-phase multisine, as lab drive files are built: every frequency line of the record carries the target
    PSD's amplitude with a uniformly random phase, so the spectrum follows the target exactly while the values are
    near-Gaussian. Rate and acceleration are exact spectral derivatives; a raised-cosine fade of `fade` s at both
    ends starts and ends it at rest.
    """
    f = np.fft.rfftfreq(n, 1 / rate)
    coeff = np.sqrt(shape.psd(f)) * np.exp(2j * math.pi * rng.random(f.size))
    jw = 2j * math.pi * f
    x, v, a = (np.fft.irfft(coeff * jw**k, n) for k in range(3))
    rms = float(np.sqrt(np.mean(x**2)))
    if rms == 0:
        raise SettingsError(f"the target spectrum {shape.describe()} has no frequency on a {n / rate:g} s grid")
    t = np.arange(n) / rate
    w, dw, ddw = _ramp(t, fade, n / rate)
    return Motion(w * x, dw * x + w * v, ddw * x + 2 * dw * v + w * a).scaled(1 / rms)
