"""Vehicle models as FMI co-simulation FMUs, built from their exact discrete step by the component FMU factory."""

from nnfmu.vehicle.fmu.errors import VehicleBuildError
from nnfmu.vehicle.fmu.settings import DEFAULT_SAMPLE_PERIOD, MAX_SUBSTEP, MODELS, VehicleBuildSettings
from nnfmu.vehicle.fmu.step_graph import discrete_step_graph, spline_terms
from nnfmu.vehicle.fmu.vehicle_fmu import (
    build_vehicle_fmu,
    initial_state,
    vehicle_component,
    vehicle_model,
    vehicle_step_graph,
)

__all__ = [
    "DEFAULT_SAMPLE_PERIOD",
    "MAX_SUBSTEP",
    "MODELS",
    "VehicleBuildError",
    "VehicleBuildSettings",
    "build_vehicle_fmu",
    "discrete_step_graph",
    "initial_state",
    "spline_terms",
    "vehicle_component",
    "vehicle_model",
    "vehicle_step_graph",
]
