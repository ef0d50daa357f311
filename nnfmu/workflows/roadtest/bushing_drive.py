"""Bushing networks trained where the car uses them: a rig record whose drive comes from the vehicle (ORIGIN.md).

A first monolithic reference of the full vehicle on its own drive seed (never the road test's) gives the front LCA
bushings' deflections; `write_vehicle_rig` derives a bushing rig drive from all four (spectrum following the
simulated one, peaks over the simulated ones by a margin, transducers sized for the test) and records the rig; the
four bushing presets are trained on that record. One set of networks serves all four bushings in the road test, so
the drive covers the envelope of all four.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import onnx

from nnfmu.component import Component
from nnfmu.data import Measurement, save_measurement
from nnfmu.data.drive_files import write_drive
from nnfmu.data.rigs import DriveDesign, RigOptions, write_vehicle_rig
from nnfmu.fmu import BuildOptions, build_fmu
from nnfmu.validate import ChannelComparison, ValidationSettings, compare
from nnfmu.vehicle import DriveSettings, generate_drive
from nnfmu.workflows.roadtest.envelope import Excursion, excursions
from nnfmu.workflows.roadtest.open_loop import fmu_ports, open_loop_replay
from nnfmu.workflows.roadtest.record_training import train_on_record
from nnfmu.workflows.roadtest.runs import RoadTestSettings
from nnfmu.workflows.roadtest.systems import (
    BUSHING_MODELS,
    RoadTestError,
    bushing_elements,
    bushing_onnx,
    vehicle_components,
)
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference
from nnfmu.workflows.train import TrainRequest

SYSTEM = "full-vehicle"


@dataclass(frozen=True)
class BushingDriveSettings:
    """`seed_offset`: the source drive's seed is the road test's plus this (non-zero: the networks are judged on a
    drive they were not derived from); `duration` [s] of the source reference (the thesis's 50 s drive: a 20 s source
    left the 50 s road test's conical rotation 8 % and its rates 25-28 % beyond the networks' envelope, margin
    included); `rig_duration` [s] of the rig record
    (None: the bushing rig's 60 s); `rig_seed`: the rig drive's phases and sensor noise; `margin` [1] of the drive's
    excursions over the simulated ones."""

    seed_offset: int = 1
    duration: float = 50.0
    rig_duration: float | None = None
    rig_seed: int = 0
    margin: float = 1.2

    def __post_init__(self) -> None:
        if self.seed_offset == 0:
            raise RoadTestError("seed_offset must not be 0: the source drive must differ from the road test's")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise RoadTestError(f"duration {self.duration!r} s of the source reference must be a positive number")


@dataclass
class VehicleBushingModels:
    """What `train_vehicle_bushings` wrote: the ONNX file per bushing preset, the source drive file and reference
    result, the rig record and its truth file, and the time [s] of each stage."""

    models: dict[str, Path]
    drive: Path
    source: Path
    rig: Path
    truth: Path
    seconds: dict[str, float] = field(default_factory=dict)


def train_vehicle_bushings(
    out: str | Path,
    road: RoadTestSettings,
    settings: BushingDriveSettings = BushingDriveSettings(),
    request: Callable[[str], TrainRequest] = lambda preset: TrainRequest(preset=preset),
    log: Callable[[str], None] = print,
) -> VehicleBushingModels:
    """Source reference (the road test's road class, speed, rate, fade-in and reference step on drive seed
    road.seed + seed_offset) -> vehicle-derived bushing rig record -> the four bushing presets trained on it, each
    with `request(preset)`; everything under `out` (source_drive.csv, source_reference.csv, rig/, models/)."""
    out = Path(out)
    seconds: dict[str, float] = {}
    seed = road.seed + settings.seed_offset
    drive = generate_drive(
        DriveSettings(
            road_class=road.road_class,
            speed=road.speed,
            seed=seed,
            duration=settings.duration + 1 / road.sample_rate,
            sample_rate=road.sample_rate,
            fade_in=road.fade_in,
        )
    )
    drive_path = write_drive(drive, out / "source_drive.csv")
    log(f"bushing rig drive: source reference of the {SYSTEM} over {settings.duration:g} s on drive seed {seed}")
    reference = monolithic_reference(SYSTEM, drive, vehicle_components(SYSTEM), road.reference_step)
    seconds["source_reference"] = reference.seconds
    source = save_measurement(reference.measurement, out / "source_reference.csv")
    started = time.perf_counter()
    elements = bushing_elements(SYSTEM)
    rig, truth = write_vehicle_rig(
        source,
        elements,
        out / "rig" / "bushing_vehicle.csv",
        RigOptions(seed=settings.rig_seed, duration=settings.rig_duration),
        DriveDesign(margin=settings.margin),
    )
    seconds["rig"] = time.perf_counter() - started
    log(f"bushing rig drive: record {rig} derived from {', '.join(elements)} (margin {settings.margin:g})")
    models = train_on_record(rig, BUSHING_MODELS, request, out / "models", seconds, log)
    return VehicleBushingModels(models, drive_path, source, rig, truth, seconds)


@dataclass
class BushingReplay:
    """Bushing networks replayed open loop along a reference's bushing motions: per element, the comparison with
    the reference's truth-physics forces per channel; and every network input's use of its training envelope on
    every bushing."""

    comparisons: dict[str, list[ChannelComparison]]
    excursions: list[Excursion]


def replay_bushing_networks(
    models: Mapping[str, Path], reference: Measurement, elements: Sequence[str], folder: Path
) -> BushingReplay:
    """The four bushing networks merged and built as the road test does (`folder`/lca-bushing.onnx/.fmu), replayed
    along each of `elements`' motion in `reference` and compared with the reference's forces and torques of that
    bushing (the truth physics; the road test budget's `nrmse_network`), and every front LCA bushing's motion against
    the networks' envelope."""
    merged = bushing_onnx(models, Path(folder) / "lca-bushing.onnx")
    fmu = build_fmu(merged, BuildOptions(out=Path(folder) / "lca-bushing.fmu"))
    outputs = list(fmu_ports(fmu, "output"))
    comparisons = {
        element: compare(
            open_loop_replay(fmu, reference, element),
            reference,
            [f"{element}_{name}" for name in outputs],
            ValidationSettings(),
        )
        for element in elements
    }
    component = Component.from_onnx(onnx.load(merged))
    return BushingReplay(comparisons, excursions("reference", bushing_elements(SYSTEM), component, reference))
