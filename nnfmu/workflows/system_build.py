"""`nnfmu system build`: an SSP system as one co-simulation FMU whose inner master is nnfmu's (docs/system-fmu.md);
the drive bound as `nnfmu cosim` binds it (a vehicle's actuator inputs)."""

from __future__ import annotations

import os
from pathlib import Path

from nnfmu.cosim import CosimSettings, SystemPlan, build_system_fmu, open_system
from nnfmu.errors import SettingsError
from nnfmu.workflows.vehicle_binding import vehicle_binding

__all__ = ["CosimSettings", "SystemPlan", "run_system_build"]


def run_system_build(
    ssd_path: str | os.PathLike[str],
    out: Path,
    step: float,
    inner_step: float | None = None,
    settings: CosimSettings | None = None,
    fmi: int = 2,
    allow_outside: bool = False,
    extrapolate_drive: bool = True,
    platforms: tuple[str, ...] | None = None,
) -> SystemPlan:
    """Build the system (.ssd, its folder or .ssp) into the FMU `out` stepping its parts at `inner_step` [s] (None:
    `step` [s], the default communication step) with the coupling `settings` (their step is not used), as an FMU of
    FMI version `fmi` (2 or 3); `extrapolate_drive` (else held) when the outer master sets no input derivatives;
    `platforms` as `nnfmu build --platforms` (None: its default), each where every part carries a binary for it."""
    if fmi not in (2, 3):
        raise SettingsError(f"--fmi {fmi}: choose 2 or 3")
    settings = settings if settings is not None else CosimSettings(port_derivatives=False)
    with open_system(ssd_path, allow_outside) as system:
        return build_system_fmu(
            system, out, step, inner_step, settings, vehicle_binding(system), fmi, extrapolate_drive, platforms
        )
