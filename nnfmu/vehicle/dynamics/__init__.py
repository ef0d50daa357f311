"""Vehicle models for the virtual road test simulator: linear(ised) state space, exact discretisation, named ports."""

from nnfmu.vehicle.dynamics.builtin_elements import LinearSpring, SplineDamper
from nnfmu.vehicle.dynamics.errors import ParameterError, VehicleModelError
from nnfmu.vehicle.dynamics.full_vehicle import build_full_vehicle
from nnfmu.vehicle.dynamics.laws import (
    BushingTruthLaw,
    ComponentLaw,
    DamperTruthLaw,
    LinearLaw,
    linear_laws,
    truth_laws,
)
from nnfmu.vehicle.dynamics.linear import DiscreteVehicle, LinearVehicle, SimulationSettings, simulate
from nnfmu.vehicle.dynamics.monolithic import MonolithicSettings, rest_state, simulate_monolithic
from nnfmu.vehicle.dynamics.parameters import DEFAULT_FILE, VehicleParameters
from nnfmu.vehicle.dynamics.ports import VehiclePort
from nnfmu.vehicle.dynamics.quarter_car import build_quarter_car
from nnfmu.vehicle.dynamics.quarter_car_parameters import QuarterCarParameters

__all__ = [
    "BushingTruthLaw",
    "ComponentLaw",
    "DEFAULT_FILE",
    "DamperTruthLaw",
    "LinearLaw",
    "MonolithicSettings",
    "QuarterCarParameters",
    "DiscreteVehicle",
    "LinearSpring",
    "LinearVehicle",
    "ParameterError",
    "SimulationSettings",
    "SplineDamper",
    "VehicleModelError",
    "VehicleParameters",
    "VehiclePort",
    "build_full_vehicle",
    "build_quarter_car",
    "linear_laws",
    "rest_state",
    "simulate",
    "simulate_monolithic",
    "truth_laws",
]
