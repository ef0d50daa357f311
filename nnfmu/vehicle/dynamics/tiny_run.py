"""The smallest compiled monolithic solve: what `kernel_warmup`'s child runs to compile (or load) the kernel."""

from __future__ import annotations

import numpy as np

from nnfmu.data.rigs import DamperParams, DamperTruth
from nnfmu.vehicle.dynamics.laws import DamperTruthLaw
from nnfmu.vehicle.dynamics.monolithic import MonolithicSettings, simulate_monolithic
from nnfmu.vehicle.dynamics.parameters import VehicleParameters
from nnfmu.vehicle.dynamics.quarter_car import build_quarter_car
from nnfmu.vehicle.dynamics.quarter_car_parameters import QuarterCarParameters


def solve_tiny_run() -> None:
    """A two-sample quarter car with the truth damper on the compiled path: the kernel compiled or loaded (child)."""
    car = build_quarter_car(QuarterCarParameters.from_vehicle(VehicleParameters.load()))
    laws = {"damper_force": DamperTruthLaw(DamperTruth(DamperParams(), ("hysteresis",)))}
    posts = {name: np.zeros(2) for name in car.input_names if name.startswith("actuator")}
    simulate_monolithic(car, laws, posts, MonolithicSettings(1e-3))
