"""Damper networks trained where the car uses them: a dyno record whose random part follows the car's damper strokes.

The source reference is the one the bushing rig drive comes from (`train_vehicle_bushings`: the full vehicle on its
own drive seed, never the road test's); `write_vehicle_damper_dyno` derives a stroke from all four dampers' and
records the dyno on the lab sine series followed by it; both damper presets (the thesis's comparison) are trained on
that record. One network serves all four corners, so the stroke covers the envelope of all four.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from nnfmu.data.rigs import RIG_BANDS, DriveDesign, RigOptions, write_vehicle_damper_dyno
from nnfmu.workflows.roadtest.record_training import train_on_record
from nnfmu.workflows.roadtest.systems import DAMPER_MODELS, damper_elements
from nnfmu.workflows.train import TrainRequest

SYSTEM = "full-vehicle"


@dataclass
class VehicleDamperModels:
    """What `train_vehicle_dampers` wrote: the ONNX file per damper preset, the dyno record and its truth file, and
    the time [s] of each stage."""

    models: dict[str, Path]
    rig: Path
    truth: Path
    seconds: dict[str, float] = field(default_factory=dict)


def train_vehicle_dampers(
    source: Path,
    out: str | Path,
    request: Callable[[str], TrainRequest],
    rig_seed: int = 0,
    margin: float = 1.2,
    rig_duration: float | None = None,
    log: Callable[[str], None] = print,
) -> VehicleDamperModels:
    """Vehicle result `source` -> vehicle-derived dyno record (margin over the simulated strokes, the dyno's band)
    -> the damper presets trained on it with `request(preset)`; everything under `out` (rig/, models/)."""
    out = Path(out)
    seconds: dict[str, float] = {}
    started = time.perf_counter()
    elements = damper_elements(SYSTEM)
    rig, truth = write_vehicle_damper_dyno(
        source,
        elements,
        out / "rig" / "damper_vehicle.csv",
        RigOptions(seed=rig_seed, duration=rig_duration),
        DriveDesign(margin=margin, band=RIG_BANDS["damper"]),
    )
    seconds["rig"] = time.perf_counter() - started
    log(f"damper dyno drive: record {rig} derived from {', '.join(elements)} (margin {margin:g})")
    models = train_on_record(rig, DAMPER_MODELS, request, out / "models", seconds, log)
    return VehicleDamperModels(models, rig, truth, seconds)
