"""The exception raised for drive-generator settings that cannot make a drive file."""

from __future__ import annotations


class DriveError(ValueError):
    """Bad drive-generator settings or events; the message names the setting or event and its value."""
