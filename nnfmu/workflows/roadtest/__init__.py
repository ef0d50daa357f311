"""Virtual road test simulator runs: quarter car and full vehicle with network FMUs vs the monolithic reference."""

from nnfmu.workflows.roadtest.bushing_drive import BushingDriveSettings, VehicleBushingModels, train_vehicle_bushings
from nnfmu.workflows.roadtest.damper_drive import VehicleDamperModels, train_vehicle_dampers
from nnfmu.workflows.roadtest.envelope import Excursion, excursion
from nnfmu.workflows.roadtest.runs import (
    RoadTestResult,
    RoadTestSettings,
    SystemResult,
    SystemRun,
    run_road_test,
    system_folder,
)
from nnfmu.workflows.roadtest.systems import (
    BUSHING_MODELS,
    DAMPER_MODELS,
    SYSTEMS,
    ComponentFmus,
    RoadTestError,
    build_component_fmus,
    build_vehicle,
    bushing_onnx,
    write_system,
)
from nnfmu.workflows.roadtest.thesis import ThesisRow, amplitude_ratio, thesis_row
from nnfmu.workflows.roadtest.truth_reference import Reference, actuator_inputs, monolithic_reference

__all__ = [
    "BUSHING_MODELS",
    "BushingDriveSettings",
    "ComponentFmus",
    "DAMPER_MODELS",
    "Excursion",
    "Reference",
    "RoadTestError",
    "RoadTestResult",
    "RoadTestSettings",
    "SYSTEMS",
    "SystemResult",
    "SystemRun",
    "ThesisRow",
    "VehicleBushingModels",
    "VehicleDamperModels",
    "actuator_inputs",
    "amplitude_ratio",
    "build_component_fmus",
    "build_vehicle",
    "bushing_onnx",
    "excursion",
    "monolithic_reference",
    "run_road_test",
    "system_folder",
    "thesis_row",
    "train_vehicle_bushings",
    "train_vehicle_dampers",
    "write_system",
]
