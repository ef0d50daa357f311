"""Vehicle models as FMI co-simulation FMUs, built from their exact discrete step by the component FMU factory."""

from .vehicle_fmu import build_vehicle_fmu, initial_state, vehicle_component, vehicle_model, vehicle_step_graph
from .errors import VehicleBuildError
from .settings import DEFAULT_SAMPLE_PERIOD, MAX_SUBSTEP, MODELS, VehicleBuildSettings
from .step_graph import discrete_step_graph, spline_terms

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
