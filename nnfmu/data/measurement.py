"""A rig measurement in SI units: channels sampled uniformly on one time axis, which the measurement owns and checks."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nnfmu.data.errors import DataError
from nnfmu.data.timebase import measurement_axis


@dataclass(frozen=True)
class Measurement:
    """Uniformly sampled channels in SI units.

    `time` [s] has shape (n,); every array in `channels` has shape (n,) and its SI unit in `units` (e.g. "m/s").
    `source` names where the data came from (a file path, or a rig simulator) for error messages and provenance.

    The measurement owns its time axis: construction refuses a `time` that is not one-dimensional, has fewer than two
    samples, a non-finite stamp, or stamps that do not increase uniformly within the clock-scatter tolerance of
    `timebase` (5 % of the period; DataError naming `source` and the first offending sample), and stores `start` [s]
    (the first stamp) and `sample_period` [s] (the mean step, (t[n-1] - t[0]) / (n - 1)), which everything else reads
    instead of deriving its own. Stamps within the sampling jitter (0.1 % of the period) of their fitted base are kept
    as given, a checked view of start + k * sample_period: files and simulators produce stamps, and keeping them makes
    saving and reloading a record exact. Stamps that scatter farther are replaced by their least-squares base, said in
    `notes["time"]` (`timebase.measurement_axis`); the loaders, which know how finely a file printed its stamps, do
    that before the measurement is made (`timebase.uniform_stamps`).
    """

    time: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str]
    source: str = "<memory>"
    notes: dict[str, str] = field(default_factory=dict)
    start: float = field(init=False)
    sample_period: float = field(init=False)

    def __post_init__(self) -> None:
        time = np.asarray(self.time, dtype=float)
        if time.ndim != 1:
            raise DataError(f"{self.source}: time must have shape (n,), has shape {time.shape}")
        if time.size < 2:
            raise DataError(
                f"{self.source}: {time.size} sample(s); a measurement needs at least 2 for its sample period"
            )
        time, note = measurement_axis(time, self.source)
        if note is not None:
            object.__setattr__(self, "notes", dict(self.notes) | {"time": note})
        object.__setattr__(self, "time", time)  # frozen: the axis and the start and period read off it stay together
        object.__setattr__(self, "start", float(time[0]))
        object.__setattr__(self, "sample_period", float(time[-1] - time[0]) / (time.size - 1))

    @classmethod
    def uniform(
        cls,
        start: float,
        period: float,
        channels: dict[str, np.ndarray],
        units: dict[str, str],
        source: str = "<memory>",
        notes: dict[str, str] | None = None,
    ) -> Measurement:
        """Channels sampled every `period` [s] from `start` [s]: t_k = start + k * period, as many as the first
        channel has."""
        if not (math.isfinite(start) and math.isfinite(period) and period > 0):
            raise DataError(
                f"{source}: a time axis needs a finite start and period > 0, not {start!r} s and {period!r} s"
            )
        if not channels:
            raise DataError(f"{source}: no channels to take the number of samples from")
        n = len(next(iter(channels.values())))
        return cls(start + np.arange(n) * period, channels, units, source, dict(notes or {}))

    @property
    def names(self) -> list[str]:
        return list(self.channels)

    def __len__(self) -> int:
        return len(self.time)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(f"{self.source}: no channel {name!r} (has: {', '.join(self.channels)})") from None

    def __contains__(self, name: str) -> bool:
        return name in self.channels

    def slice(self, start: int, stop: int) -> Measurement:
        """Samples start..stop-1 (at least two) as a new measurement (arrays are copied)."""
        return Measurement(
            time=self.time[start:stop].copy(),
            channels={k: v[start:stop].copy() for k, v in self.channels.items()},
            units=dict(self.units),
            source=f"{self.source}[{start}:{stop}]",
            notes=dict(self.notes),
        )
