"""The one exception raised for bad rig data, so callers can tell data problems from programming errors."""

from __future__ import annotations


class DataError(ValueError):
    """A problem with measured or simulated rig data; the message names the file and the channel, value or row."""
