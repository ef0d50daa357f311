"""Exceptions of the vehicle models, so callers can tell a bad parameter file or port name from a programming error."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class VehicleModelError(NnfmuError, ValueError):
    """A vehicle model cannot be built or run as asked; the message names the port, component or value."""


class ParameterError(VehicleModelError):
    """A vehicle parameter file is unreadable or holds a bad value; the message names the file and the key."""
