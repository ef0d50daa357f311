"""Feed the driven element's inputs from a drive file: by channel name, rates derived, values at any master time.

Each bound input reads the drive channel its `DriveBinding` names (a vehicle's `actuator_fl_displacement` the
channel of the same name). A rate the drive lacks (`..._velocity`) is differentiated from its displacement with the
data package's Savitzky-Golay filter (`derive_rates`). Between drive samples the values are interpolated linearly,
so the master's communication step need not equal the drive's sample period.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nnfmu.data import Measurement
from nnfmu.data.derive import derive_rates
from nnfmu.errors import NnfmuError

TIME_TOLERANCE = 1e-9  # relative to the drive's sample period: how far outside the drive a time may lie


class DriveInputError(NnfmuError, ValueError):
    """The drive cannot feed the system: a missing channel, a time outside the drive or a bad binding; names what."""


class DriveInputs:
    """Values of the drive channels `names` from `drive` at master times; `at(t)` returns them in that order."""

    def __init__(self, drive: Measurement, names: Sequence[str]) -> None:
        source = derive_rates(drive) if any(n not in drive for n in names) else drive
        missing = [n for n in names if n not in source]
        if missing:
            raise DriveInputError(
                f"{drive.source}: no channel for the bound input(s) {', '.join(map(repr, missing))} "
                f"(the drive has: {', '.join(drive.names)})"
            )
        self.names = list(names)
        self.units = [source.units.get(n, "") for n in self.names]  # SI (or kept) units of the drive channels
        self.time = np.asarray(source.time, dtype=float)
        self._columns = [np.ascontiguousarray(source[n], dtype=float) for n in self.names]
        self.source = drive.source
        self._slack = TIME_TOLERANCE * drive.sample_period

    @property
    def start(self) -> float:
        return float(self.time[0])

    @property
    def end(self) -> float:
        return float(self.time[-1])

    def at(self, t: float) -> np.ndarray:
        """Input values at time `t` [s] (linear between samples); DriveInputError outside the drive."""
        return self.table(np.array([t]))[0]

    def table(self, times: np.ndarray) -> np.ndarray:
        """Input values at each of `times` [s], one row per time (linear between samples, as `at`); DriveInputError
        naming the first time outside the drive."""
        outside = (times < self.start - self._slack) | (times > self.end + self._slack)
        if np.any(outside):
            t = float(times[np.argmax(outside)])
            raise DriveInputError(
                f"{self.source}: time {t:.9g} s lies outside the drive ({self.start:.9g} s to {self.end:.9g} s)"
            )
        clipped = np.clip(times, self.start, self.end)
        return (
            np.column_stack([np.interp(clipped, self.time, column) for column in self._columns])
            if self._columns
            else np.zeros((len(times), 0))
        )
