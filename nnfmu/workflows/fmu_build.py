"""`nnfmu build`, `nnfmu check` and `nnfmu vehicle build`: component and vehicle FMUs, and their self-check."""

from __future__ import annotations

from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.check import check_fmu, report_lines
from nnfmu.fmu.errors import PlatformSkippedWarning
from nnfmu.fmu.native.toolchain import host_binaries_only
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.package import binary_folders
from nnfmu.fmu.reference_results import has_reference_results
from nnfmu.fmu.step_graph import GRAPH_MEMBER
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu

__all__ = [
    "GRAPH_MEMBER",
    "BuildOptions",
    "PlatformSkippedWarning",
    "VehicleBuildSettings",
    "binary_folders",
    "build_fmu",
    "build_vehicle_fmu",
    "check_fmu",
    "has_reference_results",
    "host_binaries_only",
    "report_lines",
]
