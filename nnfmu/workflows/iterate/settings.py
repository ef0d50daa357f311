"""What `nnfmu iterate` may do: the iteration's options, the four-poster's actuator limits, and their checks."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from nnfmu.cosim import DEFAULT_STEP
from nnfmu.errors import NnfmuError

MAX_ITERATIONS = 100  # most drives one iteration plays
MAX_SECONDS = 3600.0  # longest target or noise record [s] (each is co-simulated several times)


class IterateError(NnfmuError, ValueError):
    """The iteration cannot run as asked: a bad option, a target channel missing or unknown; names the file,
    channel or value."""


def _positive(name: str, value: float, unit: str) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
        raise IterateError(f"{name} = {value!r} {unit} must be a positive number")


@dataclass(frozen=True)
class ActuatorLimits:
    """A four-poster's post limits, never exceeded by a drive: peak `stroke` [m] from rest, peak `velocity` [m/s],
    peak `acceleration` [m/s^2]. Defaults: a tyre-coupled road simulator's hydraulic posts (±125 mm, 2.5 m/s,
    400 m/s² ≈ 40 g); give your rig's own."""

    stroke: float = 0.125
    velocity: float = 2.5
    acceleration: float = 400.0

    def __post_init__(self) -> None:
        _positive("actuator stroke limit", self.stroke, "m")
        _positive("actuator velocity limit", self.velocity, "m/s")
        _positive("actuator acceleration limit", self.acceleration, "m/s^2")


@dataclass(frozen=True)
class IterateSettings:
    """Options of a drive-file iteration.

    `channels`: target channels to match (None: every channel of the target the system outputs); `iterations`: most
    drives played; `gain` g of drive_{k+1} = drive_k + g·H⁺·(target − response_k); `band` (low, high) [Hz] the drive
    is corrected in; `tolerance`: NRMSE every channel must reach to stop (`tolerances` per channel override it);
    `noise_level`: RMS post velocity [m/s] of the identification noise (flat velocity spectrum over the band),
    `noise_duration` [s]; `resolution` [Hz] of the FRF lines; `regularisation` ε: Tikhonov term (ε·σ_max)², σ_max
    the FRF's largest gain in the band; `reestimate`: the FRF is re-estimated from the noise run and the last so many
    iterations (0: never); `fade` [s]:
    drives rise from and fall back to rest over this time; `step` [s] the co-simulation's communication step;
    `basquin_slope` of the pseudo-damage; `seed` of the noise; `rpc`: also write the drive as RPC III (drive.drv).
    """

    channels: tuple[str, ...] | None = None
    iterations: int = 10
    gain: float = 0.8
    band: tuple[float, float] = (0.1, 100.0)
    tolerance: float = 0.05
    tolerances: Mapping[str, float] = field(default_factory=dict)
    noise_level: float = 0.1
    noise_duration: float = 60.0
    resolution: float = 0.1
    regularisation: float = 0.05
    reestimate: int = 2
    fade: float = 0.5
    step: float = DEFAULT_STEP
    limits: ActuatorLimits = field(default_factory=ActuatorLimits)
    basquin_slope: float = 5.0
    seed: int = 0
    rpc: bool = False
    allow_outside: bool = False

    def __post_init__(self) -> None:
        if isinstance(self.iterations, bool) or not isinstance(self.iterations, int):
            raise IterateError(f"iterations = {self.iterations!r} must be a whole number")
        if not 1 <= self.iterations <= MAX_ITERATIONS:
            raise IterateError(f"iterations = {self.iterations} must lie in 1 to {MAX_ITERATIONS}")
        _positive("gain", self.gain, "[1]")
        if self.gain > 2.0:
            raise IterateError(f"gain = {self.gain!r} must not exceed 2 (above it the correction overshoots)")
        low, high = self.band
        _positive("band low edge", low, "Hz")
        _positive("band high edge", high, "Hz")
        if not low < high:
            raise IterateError(f"band {low:g}:{high:g} Hz: the low edge must lie below the high edge")
        for name, value in {"tolerance": self.tolerance, **self.tolerances}.items():
            _positive(f"tolerance of {name}" if name != "tolerance" else "tolerance", value, "[1] (NRMSE)")
        _positive("noise level", self.noise_level, "m/s")
        _positive("noise duration", self.noise_duration, "s")
        if self.noise_duration > MAX_SECONDS:
            raise IterateError(f"noise duration = {self.noise_duration:g} s exceeds {MAX_SECONDS:g} s")
        _positive("FRF resolution", self.resolution, "Hz")
        if self.noise_duration * self.resolution < 4:
            raise IterateError(
                f"noise duration {self.noise_duration:g} s holds fewer than 4 segments of 1/{self.resolution:g} Hz; "
                "lengthen it or coarsen the resolution"
            )
        _positive("regularisation", self.regularisation, "[1]")
        if isinstance(self.reestimate, bool) or not isinstance(self.reestimate, int) or self.reestimate < 0:
            raise IterateError(f"reestimate = {self.reestimate!r} must be a whole number >= 0")
        _positive("fade", self.fade, "s")
        _positive("step", self.step, "s")
        _positive("Basquin slope", self.basquin_slope, "[1]")

    def tolerance_of(self, channel: str) -> float:
        """The NRMSE `channel` must reach: its own tolerance, else the common one."""
        return float(self.tolerances.get(channel, self.tolerance))


def parse_band(text: str) -> tuple[float, float]:
    """`LO:HI` [Hz] as a pair of floats; IterateError naming the text otherwise."""
    low, sep, high = text.partition(":")
    try:
        if not sep:
            raise ValueError
        return float(low), float(high)
    except ValueError:
        raise IterateError(f"--band {text!r}: give LO:HI in Hz, e.g. 0.1:100") from None


def parse_tolerance(text: str) -> tuple[float, dict[str, float]]:
    """`0.05` (every channel) or `0.05,body_acceleration=0.08` (a common value and per-channel ones) as
    (common, per channel); IterateError naming the item otherwise."""
    common, per_channel = IterateSettings.tolerance, {}
    for item in (part.strip() for part in text.split(",")):
        name, sep, value = item.rpartition("=")
        try:
            number = float(value)
        except ValueError:
            raise IterateError(f"--tolerance item {item!r}: give NRMSE or CHANNEL=NRMSE") from None
        if sep:
            per_channel[name.strip()] = number
        else:
            common = number
    return common, per_channel
