"""What a generated drive file is made of: road class, speed, vehicle geometry, rig-controller band, events."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from nnfmu.vehicle.drive.errors import DriveError
from nnfmu.vehicle.drive.events import Event, KerbStrike, Pothole

ROAD_CLASSES = ("A", "B", "C", "D", "E", "F", "G", "H")
COHERENCE_MODELS = ("isotropic", "independent", "identical")
POSITIVE_SETTINGS = {"speed": "m/s", "duration": "s", "sample_rate": "Hz", "wheelbase": "m", "track_width": "m"}
MIN_SAMPLES = 16  # the fewest samples nnfmu's measurement checks accept
MAX_SAMPLES = 10_000_000  # drive plus wheelbase delay (2.8 h at 1 kHz): the road loop is twice that, in FFTs


@dataclass(frozen=True)
class DriveSettings:
    """Settings of `generate_drive`; SI units, every field documented by its name and unit.

    road_class: ISO 8608 class "A" (best) to "H"; speed [m/s]; duration [s]; sample_rate [Hz];
    wheelbase [m] (rear axle delay = wheelbase / speed); track_width [m] (left-right distance, for the coherence);
    coherence: "isotropic" (tracks of an isotropic road surface), "independent" or "identical" tracks;
    band: (lowest, highest) spatial frequency [cycles/m] synthesised (content above the sampling's Nyquist
    frequency, sample_rate / (2 speed) cycles/m, cannot be represented and is left out); highpass / lowpass: the rig
    controller's cut-offs [Hz] (None = off), zero-phase Butterworth of `filter_order` (see `rig_filter`);
    seed: the random phases; events: potholes and kerb strikes laid over the profile; fade_in [s]: every channel
    rises from the actuators' rest position (zero) over the first fade_in seconds with a raised-cosine weight, as a
    rig drive file starts (0: the road's height and slope from the first sample, a step for a car at rest).
    """

    road_class: str = "C"
    speed: float = 20.0
    duration: float = 50.0
    sample_rate: float = 1000.0
    wheelbase: float = 2.8
    track_width: float = 1.6
    coherence: str = "isotropic"
    band: tuple[float, float] = (0.01, 10.0)
    highpass: float | None = 0.5
    lowpass: float | None = 40.0
    filter_order: int = 4
    seed: int = 0
    events: tuple[Event, ...] = ()
    fade_in: float = 0.0

    @property
    def samples(self) -> int:
        """Number of samples in the drive file: duration * sample_rate, rounded."""
        return int(round(self.duration * self.sample_rate))

    @property
    def spacing(self) -> float:
        """Distance travelled between two samples [m]."""
        return self.speed / self.sample_rate

    @property
    def axle_delay(self) -> float:
        """Time from the front axle to the rear axle passing one point [s]."""
        return self.wheelbase / self.speed

    def check(self) -> None:
        """Raise DriveError naming the first setting or event that cannot make a drive file."""
        if self.road_class not in ROAD_CLASSES:
            raise DriveError(f"unknown ISO 8608 road class {self.road_class!r}; classes are {', '.join(ROAD_CLASSES)}")
        for name, unit in POSITIVE_SETTINGS.items():
            _positive(name, getattr(self, name), unit)
        span = (self.duration + self.axle_delay) * self.sample_rate  # samples the road loop must hold
        if span > MAX_SAMPLES:
            raise DriveError(
                f"duration {self.duration:g} s plus the rear axle's delay {self.axle_delay:g} s at "
                f"{self.sample_rate:g} Hz gives {span:.4g} samples, more than the limit of {MAX_SAMPLES}; "
                f"generate shorter drives"
            )
        if self.samples < MIN_SAMPLES:
            raise DriveError(
                f"duration {self.duration:g} s at {self.sample_rate:g} Hz gives {self.samples} samples, "
                f"at least {MIN_SAMPLES} needed"
            )
        if self.coherence not in COHERENCE_MODELS:
            raise DriveError(f"unknown track coherence {self.coherence!r}; models are {', '.join(COHERENCE_MODELS)}")
        self._check_band()
        self._check_filter()
        if not (
            isinstance(self.fade_in, numbers.Real)
            and math.isfinite(self.fade_in)
            and 0 <= self.fade_in <= self.duration
        ):
            raise DriveError(
                f"fade_in must be a time between 0 and the duration {self.duration:g} s, got {self.fade_in!r}"
            )
        if not isinstance(self.seed, numbers.Integral) or self.seed < 0:
            raise DriveError(f"seed must be a non-negative integer, got {self.seed!r}")
        for event in self.events:
            if not isinstance(event, (Pothole, KerbStrike)):
                raise DriveError(f"event {event!r} is neither a Pothole nor a KerbStrike")
            event.check()
            self._check_event_fits(event)

    def _check_band(self) -> None:
        if len(self.band) != 2:
            raise DriveError(f"band {self.band!r} must be (lowest, highest) spatial frequency in cycles/m")
        low, high = self.band
        _positive("band lower limit", low, "cycles/m")
        _positive("band upper limit", high, "cycles/m")
        if low >= high:
            raise DriveError(f"band {self.band!r} cycles/m: the lower limit must be below the upper one")

    def _check_filter(self) -> None:
        nyquist = self.sample_rate / 2
        for name in ("highpass", "lowpass"):
            cutoff = getattr(self, name)
            if cutoff is not None:
                _positive(name, cutoff, "Hz")
                if cutoff >= nyquist:
                    raise DriveError(f"{name} {cutoff:g} Hz is not below the Nyquist frequency {nyquist:g} Hz")
        if self.highpass is not None and self.lowpass is not None and self.highpass >= self.lowpass:
            raise DriveError(f"highpass {self.highpass:g} Hz must lie below lowpass {self.lowpass:g} Hz")
        if not isinstance(self.filter_order, int) or self.filter_order < 1:
            raise DriveError(f"filter_order must be a positive integer, got {self.filter_order!r}")

    def _check_event_fits(self, event: Event) -> None:
        """Both axles must pass the whole event inside the drive: front from t = 0, rear before the last sample."""
        first, last = event.footprint()
        front_enters = event.time + first / self.speed
        rear_leaves = event.time + (self.wheelbase + last) / self.speed
        end = (self.samples - 1) / self.sample_rate
        if front_enters < 0:
            raise DriveError(
                f"{event.kind} at {event.time:g} s: the front axle would enter it at {front_enters:g} s, "
                f"before the drive starts"
            )
        if rear_leaves > end:
            raise DriveError(
                f"{event.kind} at {event.time:g} s: the rear axle leaves it at {rear_leaves:g} s, after the drive "
                f"ends at {end:g} s"
            )


def _positive(name: str, value: float, unit: str) -> None:
    if not (isinstance(value, numbers.Real) and math.isfinite(value) and value > 0):
        raise DriveError(f"{name} must be a positive number of {unit}, got {value!r}")
