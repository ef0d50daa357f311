"""Lab-like command signals for a semi-active damper's valve or coil: steps, ramps and band-limited random segments,
each held for a random duration within the command's range."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfilt

from nnfmu.errors import SettingsError

SEGMENT_KINDS = ("step", "ramp", "random")


@dataclass(frozen=True)
class CommandSchedule:
    """How the dyno's controller drives the command: segments of `hold` = (shortest, longest) s, each a step to a new
    level, a ramp to one, or band-limited random around one (Butterworth low-pass at `random_band` [Hz], rms a
    quarter of the range), drawn with `shares`; the command is clipped to `span` = (low, high) in its unit and held
    over the controller's sample (the record's rate)."""

    span: tuple[float, float]
    unit: str
    hold: tuple[float, float] = (0.1, 1.0)
    shares: tuple[float, float, float] = (0.4, 0.3, 0.3)
    random_band: float = 5.0

    def __post_init__(self) -> None:
        low, high = self.span
        if not (high > low and 0 < self.hold[0] <= self.hold[1] and self.random_band > 0):
            raise SettingsError(
                f"a command schedule needs span low < high, 0 < hold min <= max and a positive band; got {self}"
            )

    def signal(self, rate: float, n: int, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
        """`n` samples of the command at `rate` [Hz], and its description for the truth file."""
        low, high = self.span
        out = np.empty(n)
        counts = dict.fromkeys(SEGMENT_KINDS, 0)
        level = low
        start = 0
        band = butter(2, min(self.random_band, 0.4 * rate), fs=rate, output="sos")
        while start < n:
            length = min(n - start, max(1, int(round(rng.uniform(*self.hold) * rate))))
            kind = SEGMENT_KINDS[rng.choice(len(SEGMENT_KINDS), p=np.asarray(self.shares) / sum(self.shares))]
            target = rng.uniform(low, high)
            if kind == "step":
                part = np.full(length, target)
            elif kind == "ramp":
                part = np.linspace(level, target, length + 1)[1:]
            else:
                noise = sosfilt(band, rng.standard_normal(length + int(rate)))[int(rate) :]
                part = target + 0.25 * (high - low) * noise / max(float(np.std(noise)), 1e-12)
            out[start : start + length] = np.clip(part, low, high)
            level = out[start + length - 1]
            counts[kind] += 1
            start += length
        described = {
            "type": "steps, ramps and band-limited random segments held for random durations",
            "unit": self.unit,
            "range": [low, high],
            "hold_s": list(self.hold),
            "shares": dict(zip(SEGMENT_KINDS, self.shares)),
            "random_band_Hz": self.random_band,
            "segments": counts,
            "held_over_s": 1 / rate,
        }
        return out, described
