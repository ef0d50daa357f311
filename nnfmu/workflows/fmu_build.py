"""`nnfmu build`, `nnfmu check` and `nnfmu vehicle build`: component and vehicle FMUs, and their self-check."""

from __future__ import annotations

from nnfmu.fmu import (
    GRAPH_MEMBER,
    BuildOptions,
    PlatformSkippedWarning,
    binary_folders,
    build_fmu,
    check_fmu,
    has_reference_results,
    host_binaries_only,
    report_lines,
)
from nnfmu.vehicle import VehicleBuildSettings, build_vehicle_fmu

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
