"""A rig measurement in SI units: uniformly sampled channels over one time axis."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Measurement:
    """Uniformly sampled channels in SI units.

    `time` [s] has shape (n,); every array in `channels` has shape (n,) and its SI unit in `units` (e.g. "m/s").
    `source` names where the data came from (a file path, or a rig simulator) for error messages and provenance.
    """

    time: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str]
    source: str = "<memory>"
    notes: dict[str, str] = field(default_factory=dict)

    @property
    def sample_period(self) -> float:
        """Sampling period [s], from the first and last time stamps."""
        return float(self.time[-1] - self.time[0]) / (len(self.time) - 1)

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

    def slice(self, start: int, stop: int) -> "Measurement":
        """Samples start..stop-1 as a new measurement (arrays are copied)."""
        return Measurement(
            time=self.time[start:stop].copy(),
            channels={k: v[start:stop].copy() for k, v in self.channels.items()},
            units=dict(self.units),
            source=f"{self.source}[{start}:{stop}]",
            notes=dict(self.notes),
        )
