"""A small quarter-car system to try campaigns on without training anything: the shipped vehicle preset's quarter car
FMU, linear damper FMUs of several valvings, and a `SystemStructure.ssd` joining the vehicle to the first of them.

Everything is native FMUs built from the package's presets (no torch): the vehicle from the default parameter file
(`nnfmu vehicle build quarter-car`), each damper F = c v (`nnfmu.export.linear_damper`) with its output filter off.
The example campaign, the campaign tests and `bench/batch.py` use it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import onnx

from nnfmu.atomic import atomic_path
from nnfmu.cosim import DEFAULT_STEP, connect_by_name, write_ssd
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu import BuildOptions, build_fmu
from nnfmu.vehicle import VehicleBuildSettings, build_vehicle_fmu

DAMPER_ELEMENT = "damper"
NO_FILTER = {"filter_cutoff": 0.0}


def damper_fmu(damping: float, out: Path) -> Path:
    """A linear damper FMU F = damping * v [N.s/m] at `out`."""
    graph = out.with_suffix(".onnx")
    with atomic_path(graph) as tmp:
        onnx.save(linear_damper_graph(damping, name=out.stem.replace("-", "_")), tmp)
    return build_fmu(graph, BuildOptions(out=out))


def build_quarter_car_system(folder: Path, dampers: Mapping[str, float], step: float = DEFAULT_STEP) -> dict[str, Path]:
    """In `folder`: `quarter-car.fmu` (sampled at `step` [s]), `damper-NAME.fmu` per entry of `dampers` (name ->
    damping [N.s/m]) and `SystemStructure.ssd` with the first damper; returns the paths by name ('system',
    'vehicle', and each damper's name)."""
    folder.mkdir(parents=True, exist_ok=True)
    vehicle = build_vehicle_fmu("quarter-car", folder / "quarter-car.fmu", VehicleBuildSettings(sample_period=step))
    paths = {name: damper_fmu(damping, folder / f"damper-{name}.fmu") for name, damping in dampers.items()}
    first = paths[next(iter(dampers))]
    structure = connect_by_name(
        "quarter car", ("vehicle", vehicle), {DAMPER_ELEMENT: first}, folder, {DAMPER_ELEMENT: NO_FILTER}
    )
    return {"system": write_ssd(structure, folder / "SystemStructure.ssd"), "vehicle": vehicle} | paths
