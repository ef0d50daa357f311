"""A damper dyno: the lab's test schedule, its transducers, and the measured record of a `DamperTruth`."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from nnfmu.data.rigs.excitation import Motion, SineLevel, SpectrumShape, random_motion, sine_series, sine_series_cycles
from nnfmu.data.rigs.sensors import Sensor, record
from nnfmu.errors import SettingsError
from nnfmu.physics.damper import DamperParams, DamperTruth

UNITS = {"displacement": "m", "velocity": "m/s", "force": "N", "temperature": "K"}


# Peak velocities [m/s] of the sine series: a damper data sheet's characteristic (0.05-1.5 m/s), then a high-speed
# dyno's (2-3 m/s; servo-hydraulic and electric high-speed dynos test to 2.5-4 m/s). A car's damper goes past
# 1.5 m/s over potholes and kerbs (bench/user_path.py: -2.6 m/s in jounce, a compact car at 20 m/s over a 50 mm
# pothole), and a network trained only to 1.5 m/s extrapolates there (docs/rig-data.md).
STANDARD_PEAK_VELOCITIES = (0.05, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5)
HIGH_SPEED_PEAK_VELOCITIES = (2.0, 2.5, 3.0)

# A stroke made elsewhere (a vehicle-derived drive): (rate [Hz], samples) -> (motion, its description).
DerivedPart = Callable[[float, int], tuple[Motion, dict]]


def _default_sensors() -> dict[str, Sensor]:
    return {
        "displacement": Sensor(full_scale=0.05, noise_fraction=0.0005),  # ±50 mm LVDT, 25 um rms
        # ±5 m/s velocity transducer for the high-speed levels, 0.04 % of range: 2 mm/s rms, the noise of the ±2 m/s
        # transducer it replaced (the vehicle loop's load-cell-offset test named a gas force first at 2.5 mm/s)
        "velocity": Sensor(full_scale=5.0, noise_fraction=0.0004),
        "force": Sensor(full_scale=10e3, noise_fraction=0.001),  # ±10 kN load cell, 10 N rms
        "temperature": Sensor(full_scale=500.0, noise_fraction=0.0002),  # thermocouple on the tube, 0.1 K rms
    }


@dataclass(frozen=True)
class DamperDyno:
    """The dyno's test schedule and transducers.

    Sine series: each standard peak velocity [m/s] (the data sheet's to 1.5 m/s, then a high-speed dyno's to 3 m/s) at
    stroke amplitude min(`max_amplitude`, v/(2π·`min_frequency`)),
    i.e. >= 1 Hz and <= ±25 mm (a common dyno practice, Dixon); "lab" gives it `sine_share` of the duration.
    Random: velocity spectrum flat over 1-20 Hz (body to wheel-hop band), scaled to `random_peak_velocity` unless
    that exceeds `stroke_limit`. The truth is integrated at `internal_step` [s] or finer, then decimated.
    """

    peak_velocities: tuple[float, ...] = STANDARD_PEAK_VELOCITIES + HIGH_SPEED_PEAK_VELOCITIES
    max_amplitude: float = 0.025
    min_frequency: float = 1.0
    rest: float = 0.1  # s at rest after each level: 0.2 s before the high-speed levels, so a 40 s record still fits
    sine_share: float = 0.4
    random_shape: SpectrumShape = SpectrumShape(f_low=1.0, f_corner=1.0, f_high=20.0, slope=2.0)
    random_peak_velocity: float = 1.2
    stroke_limit: float = 0.04
    fade: float = 0.5
    internal_step: float = 0.5e-3
    sensors: dict[str, Sensor] = field(default_factory=_default_sensors)

    def sine_levels(self) -> list[SineLevel]:
        levels = []
        for v in self.peak_velocities:
            amplitude = min(self.max_amplitude, v / (2 * math.pi * self.min_frequency))
            levels.append(SineLevel(amplitude, v / (2 * math.pi * amplitude)))
        return levels

    def random(self, rate: float, n: int, rng: np.random.Generator) -> tuple[Motion, dict]:
        """Band-limited random stroke of `n` samples, scaled to the peak velocity or the stroke limit."""
        motion = random_motion(self.random_shape, rate, n, rng, min(self.fade, n / rate / 4))
        scale = min(self.random_peak_velocity / np.max(np.abs(motion.v)), self.stroke_limit / np.max(np.abs(motion.x)))
        motion = motion.scaled(scale)
        described = {
            "type": "band-limited random",
            "displacement_psd_shape": self.random_shape.describe(),
            "peak_velocity_m/s": float(np.max(np.abs(motion.v))),
            "peak_displacement_m": float(np.max(np.abs(motion.x))),
            "rms_velocity_m/s": float(np.sqrt(np.mean(motion.v**2))),
        }
        return motion, described

    def motion(
        self, excitation: str, rate: float, n: int, rng: np.random.Generator, derived: DerivedPart | None = None
    ) -> tuple[Motion, list[dict]]:
        """The prescribed stroke of `n` samples at `rate` [Hz] for excitation "lab", "random", "sine" or "vehicle"
        (the sine series as in "lab", then `derived`'s stroke for the rest instead of the band-limited random)."""
        duration = n / rate
        if excitation == "random":
            motion, described = self.random(rate, n, rng)
            return motion, [dict(described, start_s=0.0, end_s=duration)]
        levels = self.sine_levels()
        share = 1.0 if excitation == "sine" else self.sine_share
        try:
            cycles = sine_series_cycles(levels, share * duration, self.rest)
        except SettingsError as err:
            where = f"damper {excitation!r} excitation of {duration:g} s"
            raise SettingsError(f"{where}: {err} ({share:.0%} of the duration)") from None
        sine, sine_described = sine_series(levels, cycles, rate, self.rest)
        parts = [{"type": "sine series", "levels": sine_described, "start_s": 0.0, "end_s": len(sine) / rate}]
        if excitation == "sine":
            return sine.fit(n), parts
        remaining = n - len(sine)
        if remaining < 2 * self.fade * rate:
            raise SettingsError(
                f"damper 'lab' excitation of {duration:g} s leaves {remaining / rate:g} s for the random part "
                f"after the sine series; at least {2 * self.fade:g} s are needed"
            )
        if excitation == "vehicle":
            if derived is None:
                raise SettingsError(
                    "the damper's 'vehicle' excitation needs a stroke derived from a vehicle result "
                    "(nnfmu rig damper --drive-from RESULT --element NAME)"
                )
            motion, described = derived(rate, remaining)
        else:
            motion, described = self.random(rate, remaining, rng)
        parts.append(dict(described, start_s=len(sine) / rate, end_s=duration))
        return Motion.concatenate([sine, motion]), parts


def run_damper_dyno(
    params: DamperParams,
    effects: tuple[str, ...],
    dyno: DamperDyno,
    rate: float,
    n: int,
    excitation: str,
    noise: float,
    seed: int,
    derived: DerivedPart | None = None,
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Time [s], recorded channels (SI) and the truth's description of the excitation of one dyno run (`derived`: the
    vehicle-derived stroke of a "vehicle" excitation)."""
    substeps = max(1, math.ceil(1 / (rate * dyno.internal_step)))
    fine_rate = rate * substeps
    motion, parts = dyno.motion(excitation, fine_rate, n * substeps, np.random.default_rng([seed, 0]), derived)
    truth = DamperTruth(params, effects)
    force, states = truth.simulate(1 / fine_rate, motion.x, motion.v, motion.a)
    true = {"displacement": motion.x, "velocity": motion.v, "force": force}
    if "temperature" in effects:
        true["temperature"] = states[:, truth.state_names.index("temperature")]
    true = {name: values[::substeps].copy() for name, values in true.items()}
    channels = record(true, dyno.sensors, noise, seed)
    described = {
        "parts": parts,
        "integration": {
            "internal_rate_Hz": fine_rate,
            "method": "trapezoidal rule (valve force), explicit Euler (temperature)",
        },
        "sign_convention": "displacement: extension from mid-stroke (rebound +); force: tension (rebound +)",
        "recorded_velocity": "true stroke velocity plus velocity-transducer noise",
        "states": list(truth.state_names),
    }
    return np.arange(n) / rate, channels, described
