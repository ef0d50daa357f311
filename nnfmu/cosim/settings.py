"""The master's settings (`CosimSettings`) and its error, light to import: the communication step's default has its
one owner here (`DEFAULT_STEP`), which the road test, campaigns, iteration and the CLI's help read."""

from __future__ import annotations

import math
from dataclasses import dataclass

from nnfmu.errors import NnfmuError

DEFAULT_STEP = 1e-3  # [s] the communication step when none is given: the networks' usual sample period
SCHEMES = ("gauss-seidel", "jacobi")
ORDERS = ("components-first", "vehicle-first")
EXTRAPOLATIONS = ("none", "linear")
INNER_LOOPS = ("auto", "c", "python")


class CosimError(NnfmuError, ValueError):
    """The system or settings cannot be co-simulated; the message names the element, connector or setting."""


@dataclass(frozen=True)
class CosimSettings:
    """Communication `step` [s]; `stop_time` [s] (None: the system's default experiment, else the last whole step
    within the drive).

    `scheme` 'gauss-seidel' (elements one after another in `order`) or 'jacobi' (all on the same values);
    `extrapolation` of coupling signals over a step, 'none' or 'linear'; `refresh`: give elements with feedthrough
    their inputs at t_{n+1} after the step and read their outputs again; `iterations`: most repeats of a step for
    strong coupling (0: none), until the t_{n+1} values change by less than `tolerance` of their peak. The defaults
    are the accurate one-pass scheme of `master.py`'s docstring. `order` 'vehicle-first' steps the driven element
    (the binding's, see `binding.py`) first. `inner_loop`: 'auto' steps one-pass schemes of FMI 2 FMUs
    in compiled C where a host compiler is found (`inner_loop.py`; same numbers), else in Python; 'python' always
    in Python; 'c' requires the C loop. `port_derivatives`: set an element's port derivative inputs (nnfmu's
    vehicle built with them: its stabilised ports' stiffness and damping) from the connected components'
    directional derivatives every step (`port_derivatives.py`; such a run steps in Python).
    """

    step: float = DEFAULT_STEP
    stop_time: float | None = None
    start_time: float = 0.0
    scheme: str = "gauss-seidel"
    order: str = "vehicle-first"
    extrapolation: str = "linear"
    refresh: bool = True
    iterations: int = 0
    tolerance: float = 1e-10
    inner_loop: str = "auto"
    port_derivatives: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.step) and self.step > 0):
            raise CosimError(f"communication step {self.step!r} must be a positive number of seconds")
        for name, value, choices in (
            ("scheme", self.scheme, SCHEMES),
            ("order", self.order, ORDERS),
            ("extrapolation", self.extrapolation, EXTRAPOLATIONS),
            ("inner_loop", self.inner_loop, INNER_LOOPS),
        ):
            if value not in choices:
                raise CosimError(f"{name} {value!r} is not one of {', '.join(choices)}")
        if not (isinstance(self.iterations, int) and self.iterations >= 0):
            raise CosimError(f"iterations {self.iterations!r} must be a whole number >= 0")
        if not (self.tolerance > 0):
            raise CosimError(f"tolerance {self.tolerance!r} must be positive")

    @property
    def plain(self) -> bool:
        """No estimate of the step's end: every input takes the latest value (what a basic master does)."""
        return self.extrapolation == "none" and self.iterations == 0
