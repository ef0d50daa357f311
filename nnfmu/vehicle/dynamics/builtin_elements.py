"""Built-in reference elements that stand in for external components: the spline damper and the linear bushing."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.vehicle.dynamics.errors import VehicleModelError


@dataclass(frozen=True)
class SplineDamper:
    """Piecewise-linear force-velocity table (rebound positive), extended linearly beyond its end points.

    This is the one-to-one "spline" damper a vehicle model usually carries (no hysteresis); nonlinear, so a model that
    uses it is stepped with a fine internal sub-step (see `linear.DiscreteVehicle`).
    """

    velocity: tuple[float, ...]
    force: tuple[float, ...]

    def __post_init__(self) -> None:
        v = np.asarray(self.velocity, dtype=float)
        if v.shape != np.shape(self.force) or v.size < 2 or np.any(np.diff(v) <= 0.0):
            raise VehicleModelError(
                "spline damper needs strictly increasing velocities and as many forces"
                f" (got {self.velocity}, {self.force})"
            )

    def __call__(self, velocity: np.ndarray | float) -> np.ndarray:
        """Force [N] at `velocity` [m/s] (any shape)."""
        v = np.asarray(self.velocity, dtype=float)
        f = np.asarray(self.force, dtype=float)
        x = np.asarray(velocity, dtype=float)
        slope_lo = (f[1] - f[0]) / (v[1] - v[0])
        slope_hi = (f[-1] - f[-2]) / (v[-1] - v[-2])
        inside = np.interp(x, v, f)
        below = f[0] + slope_lo * (x - v[0])
        above = f[-1] + slope_hi * (x - v[-1])
        return np.where(x < v[0], below, np.where(x > v[-1], above, inside))


@dataclass(frozen=True)
class LinearSpring:
    """A linear spring-damper on one deflection: force = preload + stiffness * deflection + damping * rate."""

    stiffness: float
    damping: float
    preload: float = 0.0
