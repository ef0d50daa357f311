"""The one exception raised for bad rig data, so callers can tell data problems from programming errors."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class DataError(NnfmuError, ValueError):
    """A problem with measured or simulated rig data; the message names the file and the channel, value or row."""
