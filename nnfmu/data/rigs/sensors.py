"""Rig transducers: white noise of a fraction of full scale and ADC quantisation, applied to the true signals.

Typical lab transducers (LVDTs, strain-gauge load cells, thermocouples) are specified at 0.05-0.3 % of full scale;
a 16-bit acquisition over ±full scale quantises in steps of 2·FS/2^16. A recorded velocity is the true velocity
plus the velocity transducer's noise (a dyno's velocity channel comes from a velocity transducer or the
controller's filtered derivative of the LVDT, not from a raw difference of noisy positions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ADC_BITS = 16
RANGE_MANTISSAS = (1.0, 2.0, 5.0)  # transducer full scales come in a 1-2-5 series per decade, as catalogues list them


@dataclass(frozen=True)
class Sensor:
    """A transducer channel: ±`full_scale` (SI unit of the channel) and rms noise as a `noise_fraction` of it."""

    full_scale: float
    noise_fraction: float

    @property
    def noise_rms(self) -> float:
        return self.full_scale * self.noise_fraction

    @property
    def resolution(self) -> float:
        return 2 * self.full_scale / 2**ADC_BITS

    def measure(self, true: np.ndarray, noise: float, rng: np.random.Generator) -> np.ndarray:
        """The recorded signal: true + noise·noise_rms·N(0,1), quantised to the ADC; `noise` = 0 returns `true`."""
        if noise == 0:
            return np.array(true, dtype=float)
        noisy = true + noise * self.noise_rms * rng.standard_normal(len(true))
        return np.round(noisy / self.resolution) * self.resolution

    def describe(self) -> dict[str, float]:
        return {"full_scale": self.full_scale, "noise_rms": self.noise_rms, "adc_resolution": self.resolution}

    def sized_for(self, peak: float, headroom: float) -> "Sensor":
        """The same kind of transducer with the range a lab would pick for a test reaching `peak`: the smallest
        1-2-5 full scale at or above headroom·peak, never above this sensor's own; same noise as a share of range."""
        needed = headroom * abs(peak)
        if not (math.isfinite(needed) and needed > 0):
            return self
        decade = 10.0 ** math.floor(math.log10(needed))
        full_scale = min(m * decade * f for f in (1.0, 10.0) for m in RANGE_MANTISSAS if m * decade * f >= needed)
        return Sensor(min(full_scale, self.full_scale), self.noise_fraction)


def record(true: dict[str, np.ndarray], sensors: dict[str, Sensor], noise: float, seed: int) -> dict[str, np.ndarray]:
    """Measure every channel of `true` with its sensor; each channel's noise comes from its own stream of `seed`."""
    streams = np.random.SeedSequence([seed, 1]).spawn(len(true))
    return {
        name: sensors[name].measure(values, noise, np.random.default_rng(stream))
        for (name, values), stream in zip(true.items(), streams)
    }
