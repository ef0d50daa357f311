"""The error a vehicle FMU build raises for a bad model name, component choice or sample period."""

from __future__ import annotations

from nnfmu.vehicle.dynamics.errors import VehicleModelError


class VehicleBuildError(VehicleModelError):
    """A vehicle FMU cannot be built as asked; the message names the setting and its value."""
