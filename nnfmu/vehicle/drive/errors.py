"""The exception raised for drive-generator settings that cannot make a drive file."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class DriveError(NnfmuError, ValueError):
    """Bad drive-generator settings or events; the message names the setting or event and its value."""
