"""`nnfmu iterate`: read the target record and the virtual car's SSP system, iterate a drive through the
co-simulation master, write drive.csv, report.json and report.html into the output folder (replaced as a whole)."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nnfmu.atomic import staging_dir
from nnfmu.cosim import CosimSettings, DriveBinding, InstancePool, SystemStructure
from nnfmu.data import Measurement
from nnfmu.data.drive_files import RPC_SUFFIXES, read_drive, write_drive
from nnfmu.data.load import load_measurement
from nnfmu.out_paths import check_output_dir, replace_output_dir
from nnfmu.workflows.iterate.loop import Log, Outcome, iterate
from nnfmu.workflows.iterate.report import write_report
from nnfmu.workflows.iterate.settings import MAX_SECONDS, IterateError, IterateSettings
from nnfmu.workflows.iterate.signals import rates
from nnfmu.workflows.system import VirtualSystem

KIND = "iterate"
DISPLACEMENT, VELOCITY = "_displacement", "_velocity"
PROBE_SECONDS = 0.01  # rest run that lists the system's output channels before any real work


@dataclass
class IterateResult:
    """The drive returned (the best iteration's, time from 0, SI units), the iteration's outcome, the target channels
    matched and the files written."""

    drive: Measurement
    outcome: Outcome
    channels: list[str]
    files: dict[str, Path]

    @property
    def converged(self) -> bool:
        return self.outcome.converged


def read_target(path: str | os.PathLike[str]) -> Measurement:
    """A road record: RPC III by suffix, else any file `load_measurement` reads (CSV, MDF4, MTS export)."""
    return read_drive(path) if Path(path).suffix.lower() in RPC_SUFFIXES else load_measurement(path)


def actuator_channels(binding: DriveBinding, system: SystemStructure) -> tuple[list[str], list[str]]:
    """The drive's displacement channels (one per post) and the velocity channels the binding also reads (each the
    rate of its displacement); IterateError for a bound input that is neither."""
    displacements = [c for c in binding.channels if c.endswith(DISPLACEMENT)]
    velocities = [c for c in binding.channels if c.endswith(VELOCITY)]
    other = [c for c in binding.channels if c not in displacements and c not in velocities]
    unpaired = [c for c in velocities if c[: -len(VELOCITY)] + DISPLACEMENT not in displacements]
    if other or unpaired or not displacements:
        raise IterateError(
            f"system {system.name!r}: element {binding.element!r} reads drive channel(s) "
            f"{', '.join(other + unpaired) or 'none'}; iterate drives post displacements (`..._displacement`, with "
            "their `..._velocity`)"
        )
    return displacements, velocities


class SystemPlant:
    """The virtual car as a plant: a drive (n, m) every dt -> its outputs at the drive's times, co-simulated in
    memory by the master on the system's drive binding (instances kept in a pool between runs)."""

    def __init__(self, system: VirtualSystem, displacements: Sequence[str], dt: float, step: float) -> None:
        self.system, self.dt, self.step = system, dt, step
        self.displacements = list(displacements)
        self.pool = InstancePool()
        self.channels: list[str] = []

    def drive(self, x: np.ndarray) -> Measurement:
        """Drive record of displacements `x` (n, m) [m] with their velocities [m/s], time from 0."""
        v, _ = rates(x, self.dt)
        channels, units = {}, {}
        for j, name in enumerate(self.displacements):
            rate = name[: -len(DISPLACEMENT)] + VELOCITY
            channels |= {name: x[:, j], rate: v[:, j]}
            units |= {name: "m", rate: "m/s"}
        return Measurement.uniform(0.0, self.dt, channels=channels, units=units, source="nnfmu iterate drive")

    def outputs(self, x: np.ndarray) -> Measurement:
        """Every output of the system for drive `x`, at the drive's times (linear between communication points)."""
        drive = self.drive(x)
        steps = math.floor(float(drive.time[-1]) / self.step + 1e-9)
        settings = CosimSettings(step=self.step, stop_time=steps * self.step)
        result = self.system.cosimulate(drive, settings, pool=self.pool).measurement
        t = drive.time
        return Measurement.uniform(
            0.0,
            self.dt,
            channels={c: np.interp(t, result.time, result[c]) for c in result.names},
            units=dict(result.units),
            source=result.source,
        )

    def __call__(self, x: np.ndarray) -> np.ndarray:
        out = self.outputs(x)
        return np.column_stack([out[c] for c in self.channels])


def _choose_channels(target: Measurement, outputs: Measurement, settings: IterateSettings, system: Path) -> list[str]:
    recorded = [c for c in target.names if f"derived:{c}" not in target.notes]
    if settings.channels is not None:
        for name in settings.channels:
            if name not in recorded:
                raise IterateError(
                    f"{target.source}: no channel {name!r} in the target (it has: {', '.join(recorded)})"
                )
            if name not in outputs.names:
                raise IterateError(
                    f"{system}: channel {name!r} of the target is not an output of the system (outputs: "
                    f"{', '.join(outputs.names)})"
                )
        chosen = list(settings.channels)
    else:
        chosen = [c for c in recorded if c in outputs.names]
    if not chosen:
        raise IterateError(
            f"{target.source}: no channel of the target is an output of the system {system} (target: "
            f"{', '.join(recorded)}; outputs: {', '.join(outputs.names)})"
        )
    unknown = [name for name in settings.tolerances if name not in chosen]
    if unknown:
        raise IterateError(
            f"--tolerance names channel(s) {', '.join(map(repr, unknown))} that are not targets "
            f"(targets: {', '.join(chosen)})"
        )
    for name in chosen:
        if target.units.get(name, "") != outputs.units.get(name, ""):
            raise IterateError(
                f"{target.source}: channel {name!r} is in {target.units.get(name)!r}, the system's output in "
                f"{outputs.units.get(name)!r}"
            )
    return chosen


def _check_record(target: Measurement, settings: IterateSettings, path: Path) -> float:
    dt = target.sample_period
    duration = float(target.time[-1] - target.time[0])
    if duration > MAX_SECONDS:
        raise IterateError(f"{path}: {duration:g} s of target; iterate takes at most {MAX_SECONDS:g} s")
    nyquist = 0.5 / max(dt, settings.step)
    if settings.band[1] > nyquist:
        raise IterateError(
            f"band {settings.band[0]:g}:{settings.band[1]:g} Hz: the high edge lies above {nyquist:g} Hz, the Nyquist "
            f"frequency of {path} (sample period {dt:g} s) and the co-simulation step ({settings.step:g} s)"
        )
    if duration < 4.0 * settings.fade:
        raise IterateError(
            f"{path}: {duration:g} s of target are too short to fade in and out over {settings.fade:g} s"
        )
    return dt


def run_iterate(
    target_path: str | os.PathLike[str],
    system_path: str | os.PathLike[str] | VirtualSystem,
    out_dir: str | os.PathLike[str],
    settings: IterateSettings | None = None,
    log: Log = lambda _: None,
) -> IterateResult:
    """Iterate a drive that makes the system's outputs match the target record's channels; write drive.csv (what
    `nnfmu cosim --drive` reads), report.json and report.html into `out_dir`; `system_path` may be a system in
    memory."""
    settings = settings or IterateSettings()
    given = system_path
    target_path = Path(target_path)
    system_file = given.structure.path if isinstance(given, VirtualSystem) else Path(given)
    out = check_output_dir(out_dir, KIND, [target_path, *([system_file] if system_file else [])], replaces=True)
    target = read_target(target_path)
    dt = _check_record(target, settings, target_path)
    with VirtualSystem.open(given, settings.allow_outside) as system:
        system_path = system_file or system.where
        binding = system.drive_binding()
        displacements, _ = actuator_channels(binding, system.structure)
        plant = SystemPlant(system.bind(binding), displacements, dt, settings.step)
        try:
            probe = plant.outputs(np.zeros((max(2, round(PROBE_SECONDS / dt) + 1), len(displacements))))
            channels = _choose_channels(target, probe, settings, system_path)
            plant.channels = channels
            log(f"matching {', '.join(channels)} with {', '.join(displacements)}")
            values = np.column_stack([target[c] for c in channels])
            outcome = iterate(plant, values, dt, channels, len(displacements), settings, log)
        finally:
            plant.pool.close()
    best = outcome.iterations[outcome.best]
    drive = plant.drive(best.drive)
    out.parent.mkdir(parents=True, exist_ok=True)
    with staging_dir(out.parent, f".{out.name}.staging-") as staging:
        files = {"drive": write_drive(drive, staging / "drive.csv")}
        if settings.rpc:
            files["drive_rpc"] = write_drive(drive, staging / "drive.drv")
        write_report(staging, outcome, values, dt, channels, displacements, settings, target, system_path)
        replace_output_dir(staging, out, KIND)
    files = {key: out / path.name for key, path in files.items()} | {
        "report": out / "report.json",
        "html": out / "report.html",
    }
    log(
        f"{'converged' if outcome.converged else 'not converged'}: best iteration {best.index} of "
        f"{len(outcome.iterations)}; drive: {files['drive']}"
    )
    return IterateResult(drive, outcome, channels, files)
