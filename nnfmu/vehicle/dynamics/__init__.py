"""Vehicle models for the virtual road test simulator: linear(ised) state space, exact discretisation, named ports."""

from .errors import ParameterError, VehicleModelError
from .full_vehicle import build_full_vehicle
from .laws import BushingTruthLaw, ComponentLaw, DamperTruthLaw, LinearLaw, linear_laws, truth_laws
from .linear import DiscreteVehicle, LinearVehicle, SimulationSettings, simulate
from .monolithic import MonolithicSettings, rest_state, simulate_monolithic
from .parameters import DEFAULT_FILE, VehicleParameters
from .ports import VehiclePort
from .quarter_car import build_quarter_car
from .quarter_car_parameters import QuarterCarParameters
from .builtin_elements import LinearSpring, SplineDamper

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
