"""Discrete road events laid over the random profile: a pothole (cosine dip) and a kerb strike (raised step).

Each event is a shape of road height over the distance `s` [m] from its centre, so front and rear axles see the same
shape at their own times. `time` [s] is when the FRONT axle reaches the centre; the rear axle reaches it one
wheelbase later. `side` is the wheel track hit: "left", "right" or "both".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from nnfmu.vehicle.drive.errors import DriveError

SIDES = ("left", "right", "both")


def _raised_step(u: np.ndarray) -> np.ndarray:
    """0 for u <= -1/2, 1 for u >= 1/2, and the half sine (1 + sin(pi u)) / 2 between (smooth in slope)."""
    return np.where(u <= -0.5, 0.0, np.where(u >= 0.5, 1.0, 0.5 * (1.0 + np.sin(np.pi * np.clip(u, -0.5, 0.5)))))


@dataclass(frozen=True)
class Pothole:
    """A cosine-shaped dip `depth` [m] deep and `length` [m] long, deepest at its centre."""

    kind: ClassVar[str] = "pothole"

    time: float
    depth: float = 0.05
    length: float = 0.6
    side: str = "left"

    def footprint(self) -> tuple[float, float]:
        """First and last distance from the centre [m] where the event changes the road."""
        return -self.length / 2, self.length / 2

    def shape(self, s: np.ndarray) -> np.ndarray:
        """Road height change [m] at distances `s` [m] from the centre: -depth (1 + cos(2 pi s / length)) / 2."""
        inside = np.abs(s) <= self.length / 2
        return np.where(inside, -0.5 * self.depth * (1.0 + np.cos(2 * np.pi * s / self.length)), 0.0)

    def check(self) -> None:
        """Raise DriveError naming the event and the first bad value."""
        _check_common(self, {"depth": self.depth, "length": self.length})


@dataclass(frozen=True)
class KerbStrike:
    """The wheel climbs a kerb `height` [m] high over `ramp_length` [m], runs `length` [m] on it and drops back.

    The climb is a half-sine ramp centred on the event centre (height/2 there), the drop one centred `length` later.
    """

    kind: ClassVar[str] = "kerb strike"

    time: float
    height: float = 0.1
    ramp_length: float = 0.1
    length: float = 2.0
    side: str = "right"

    def footprint(self) -> tuple[float, float]:
        """First and last distance from the centre [m] where the event changes the road."""
        return -self.ramp_length / 2, self.length + self.ramp_length / 2

    def shape(self, s: np.ndarray) -> np.ndarray:
        """Road height change [m] at distances `s` [m] from the centre (the middle of the climb)."""
        return self.height * (_raised_step(s / self.ramp_length) - _raised_step((s - self.length) / self.ramp_length))

    def check(self) -> None:
        """Raise DriveError naming the event and the first bad value."""
        _check_common(self, {"height": self.height, "ramp_length": self.ramp_length, "length": self.length})
        if self.length < self.ramp_length:
            raise DriveError(
                f"kerb strike at {self.time:g} s: length {self.length:g} m is shorter than its ramp "
                f"{self.ramp_length:g} m"
            )


Event = Pothole | KerbStrike


def _check_common(event: Event, positives: dict[str, float]) -> None:
    kind = event.kind
    if not math.isfinite(event.time):
        raise DriveError(f"{kind}: time {event.time!r} is not a finite number of seconds")
    for name, value in positives.items():
        if not (math.isfinite(value) and value > 0):
            raise DriveError(f"{kind} at {event.time:g} s: {name} must be a positive number of metres, got {value!r}")
    if event.side not in SIDES:
        raise DriveError(f"{kind} at {event.time:g} s: side {event.side!r} is not one of {', '.join(SIDES)}")


def hits(event: Event, side: str) -> bool:
    """Whether `event` lies in the wheel track `side` ("left" or "right")."""
    return event.side in (side, "both")
