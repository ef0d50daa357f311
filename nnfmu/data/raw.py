"""What every file reader returns: channels as stored in the file, before conversion to SI."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nnfmu.data.timebase import Resolution


@dataclass
class RawTable:
    """A time column and named channels, each with the unit text found in the file (not yet checked or converted).

    `time` and every array in `channels` have shape (n,); `units` maps each channel name to its unit text.
    `time_resolution` is how finely the file stores the stamps (in `time_unit`; None: exactly, as binary float64),
    `notes` what the reader wants the user to know (format, channel names it mapped or left out).
    """

    time: np.ndarray
    time_unit: str
    channels: dict[str, np.ndarray]
    units: dict[str, str]
    time_resolution: Resolution | None = None
    notes: dict[str, str] = field(default_factory=dict)
