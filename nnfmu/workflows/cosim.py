"""`nnfmu cosim`: read an SSP system and a drive file, bind the drive to the vehicle, co-simulate, write the result."""

from __future__ import annotations

import json
import os
import warnings

from nnfmu.atomic import write_text_atomic
from nnfmu.cosim import (
    DEFAULT_TARGET,
    CosimResult,
    CosimSettings,
    CosimWarning,
    Progress,
    StepStudy,
    cosimulate,
    cosimulate_compiled,
    open_system,
    save_result,
    study_lines,
    study_step,
)
from nnfmu.data.drive_files import read_drive
from nnfmu.errors import SettingsError
from nnfmu.workflows.system import VirtualSystem
from nnfmu.workflows.training_range import training_range_lines
from nnfmu.workflows.vehicle_binding import vehicle_binding

__all__ = ["DEFAULT_TARGET", "ENGINES", "CosimSettings", "CosimWarning", "run_cosim", "run_step_study", "study_lines"]

MASTERS = ("fmpy", "libcosim")
ENGINES = ("python", "compiled")  # the fmpy master's loop in Python (C inner loop), or the system FMU stepped from C


def run_cosim(
    ssd_path: str | os.PathLike[str],
    drive_path: str | os.PathLike[str],
    settings: CosimSettings,
    out_path: str | os.PathLike[str] | None = None,
    progress: Progress | None = None,
    master: str = "fmpy",
    allow_outside: bool = False,
    engine: str = "python",
) -> CosimResult:
    """Co-simulate the system (.ssd, folder or .ssp) on the drive file with `master` (fmpy, this package's master, or
    libcosim, the cross-check); write the result to `out_path` when given. The fmpy master runs on `engine`:
    'python' (`cosimulate`) or 'compiled' (`cosimulate_compiled`: the system built once into a cached system FMU and
    stepped from C; one-pass schemes only, the same result). The system's FMUs may lie outside its folder only if
    `allow_outside`. A network input the run drove outside its training envelope is a `CosimWarning`
    (`training_range_lines`)."""
    if master not in MASTERS:
        raise SettingsError(f"unknown master {master!r}; use {' or '.join(MASTERS)}")
    check_engine(engine, master)
    drive = read_drive(drive_path)
    with VirtualSystem.open(ssd_path, allow_outside) as opened:
        system = opened.bind(opened.drive_binding())
        if master == "libcosim":
            from nnfmu.cosim import run_libcosim

            result = run_libcosim(ssd_path, drive, settings, system.drive_binding(), allow_outside)
        elif engine == "compiled":
            result = cosimulate_compiled(system.structure, drive, settings, progress, binding=system.drive_binding())
        else:
            result = system.cosimulate(drive, settings, progress=progress)
        for line in training_range_lines(system, result.measurement):
            warnings.warn(line, CosimWarning, stacklevel=2)
    if out_path is not None:
        save_result(result, out_path)
    return result


def check_engine(engine: str, master: str = "fmpy") -> None:
    """SettingsError for an unknown engine, or the compiled engine asked of another master than fmpy."""
    if engine not in ENGINES:
        raise SettingsError(f"unknown engine {engine!r}; use {' or '.join(ENGINES)}")
    if engine == "compiled" and master != "fmpy":
        raise SettingsError(
            f"the compiled engine runs nnfmu's own coupling (master fmpy); master {master!r} runs its own algorithm"
        )


def run_step_study(
    ssd_path: str | os.PathLike[str],
    drive_path: str | os.PathLike[str],
    settings: CosimSettings,
    json_path: str | os.PathLike[str] | None = None,
    target: float = DEFAULT_TARGET,
    out_path: str | os.PathLike[str] | None = None,
) -> StepStudy:
    """Co-simulate the system at settings.step, its half and quarter (fmpy master) and estimate each channel's
    coupling error at the step (`nnfmu.cosim.step_study`); write the study as JSON to `json_path` and the run at
    the step to `out_path` when given."""
    drive = read_drive(drive_path)
    first: list[CosimResult] = []

    with open_system(ssd_path) as system:
        binding = vehicle_binding(system)

        def run(each: CosimSettings) -> CosimResult:
            result = cosimulate(system, drive, each, binding=binding)
            if not first:
                first.append(result)
            return result

        study = study_step(system, settings, run, target)
    if out_path is not None:
        save_result(first[0], out_path)
    if json_path is not None:
        write_text_atomic(json_path, json.dumps(study.as_dict(), indent=2) + "\n")
    return study
