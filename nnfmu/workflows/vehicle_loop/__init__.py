"""Closing the loop at vehicle level: lab road-test channels -> which component, which effect -> fixed FMU ->
vehicle error before and after (`run_vehicle_loop`)."""

from nnfmu.workflows.vehicle_loop.run import VehicleLoopReport, run_vehicle_loop
from nnfmu.workflows.vehicle_loop.settings import VehicleLoopError, VehicleLoopSettings

__all__ = ["VehicleLoopError", "VehicleLoopReport", "VehicleLoopSettings", "run_vehicle_loop"]
