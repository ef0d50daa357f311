"""What every file reader returns: channels as stored in the file, before conversion to SI."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class RawTable:
    """A time column and named channels, each with the unit text found in the file (not yet checked or converted).

    `time` and every array in `channels` have shape (n,); `units` maps each channel name to its unit text.
    """

    time: np.ndarray
    time_unit: str
    channels: dict[str, np.ndarray]
    units: dict[str, str]
