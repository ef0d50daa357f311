"""The shipped road-test systems as FMUs and SSP files: a quarter car with a damper network, and the full vehicle with
four damper networks and its four front lower-control-arm (LCA) bushings as network FMUs (the thesis's set-up).

A bushing has one network per channel (axial and radial force, axial and conical torque); `bushing_onnx` merges them
into one step graph (`nnfmu.export.merge`), so one FMU per bushing carries all four and its ports (`axial_force`,
`axial_displacement`, ...) meet the vehicle's `bushing_fl_front_axial_force` etc. by `connect_by_name`'s rule.
Every element is a native FMU. The vehicle's dampers are external force ports; its LCA bushings are stabilised
ports (`nnfmu.vehicle.dynamics.linear`): a 4.5 kg arm on bushings of several kN/mm has modes near 240 Hz, which a force
held for the networks' 1 ms cannot carry (every plain exchange diverges within milliseconds), so the vehicle keeps the
linear bushing over each step and applies the network force plus the linear bushing's change since the step start;
that bushing is fitted to the networks' own stiffness and damping over a sample (`stabilisers`) rather than taken
from the parameter file. The vehicle FMU samples at the communication step, so each step starts at a sample.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import onnx

from nnfmu.atomic import atomic_path
from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.errors import NnfmuError
from nnfmu.export.merge import merge_step_graphs
from nnfmu.fmu import BuildOptions, build_fmu
from nnfmu.vehicle import CORNERS, FRONT_CORNERS, STABILISED, VehicleBuildSettings, build_vehicle_fmu, truth_laws
from nnfmu.workflows.roadtest.truth_graphs import bushing_truth_graph, damper_truth_graph
from nnfmu.workflows.roadtest.truth_reference import settled_state
from nnfmu.workflows.system import FmuCache, VirtualSystem

SYSTEMS = ("quarter-car", "full-vehicle")
DAMPER_MODELS = ("damper-spline", "damper-hysteresis")
BUSHING_MODELS = ("bushing-axial-force", "bushing-radial-force", "bushing-axial-torque", "bushing-conical-torque")


class RoadTestError(NnfmuError, ValueError):
    """A road test cannot be set up or run as asked; the message names the system, model file or setting."""


def damper_elements(system: str) -> list[str]:
    """SSD element names of the dampers of `system`, named like the vehicle's ports ('damper', 'damper_fl', ...)."""
    return ["damper"] if system == "quarter-car" else [f"damper_{c}" for c in CORNERS]


def bushing_elements(system: str) -> list[str]:
    """SSD element names of the network bushings of `system`: the front LCA bushings of the full vehicle."""
    return [] if system == "quarter-car" else [f"bushing_{c}_{p}" for c in FRONT_CORNERS for p in ("front", "rear")]


def check_models(models: Mapping[str, Path], system: str) -> None:
    """Every ONNX file `system` needs is named in `models` and exists; RoadTestError lists what is missing."""
    if system not in SYSTEMS:
        raise RoadTestError(f"unknown road-test system {system!r}; choose one of {', '.join(SYSTEMS)}")
    needed = DAMPER_MODELS + (BUSHING_MODELS if bushing_elements(system) else ())
    missing = [m for m in needed if m not in models]
    if missing:
        raise RoadTestError(f"{system}: no ONNX file given for {', '.join(missing)} (given: {', '.join(models)})")
    absent = [f"{m}: {models[m]}" for m in needed if not Path(models[m]).is_file()]
    if absent:
        raise RoadTestError(f"{system}: ONNX file(s) not found: {'; '.join(absent)}")


def bushing_onnx(models: Mapping[str, Path], out: Path) -> Path:
    """Merge the four bushing channel networks into one step graph at `out` (written atomically)."""
    parts = [onnx.load(Path(models[name])) for name in BUSHING_MODELS]
    merged = merge_step_graphs(
        parts,
        "lca_bushing",
        "front LCA bushing: axial and radial force, axial and conical torque networks in one step graph",
    )
    with atomic_path(out) as tmp:
        onnx.save(merged, tmp)
    return out


@dataclass(frozen=True)
class ComponentFmus:
    """The network FMUs of one road test: one per damper model, and the merged bushing (None if not built)."""

    dampers: dict[str, Path]
    bushing: Path | None


def build_component_fmus(models: Mapping[str, Path], out: Path, with_bushing: bool) -> ComponentFmus:
    """Native FMUs of the damper networks (and the merged bushing when `with_bushing`) in `out`; each carries its
    step graph (`nnfmu.fmu.step_graph`), so the systems built from them are ready for `nnfmu loop vehicle`."""
    out.mkdir(parents=True, exist_ok=True)
    dampers = {name: build_fmu(Path(models[name]), BuildOptions(out=out / f"{name}.fmu")) for name in DAMPER_MODELS}
    bushing = None
    if with_bushing:
        merged = bushing_onnx(models, out / "lca-bushing.onnx")
        bushing = build_fmu(merged, BuildOptions(out=out / "lca-bushing.fmu"))
    return ComponentFmus(dampers, bushing)


def build_truth_fmus(out: Path, sample_period: float, with_bushing: bool) -> ComponentFmus:
    """Native FMUs of the truth physics the monolithic reference closes the vehicle with (`truth_laws`), sampled at
    the networks' `sample_period` [s]: the damper as `dampers["truth"]`, and the bushing (all four channels)."""
    forces = ["damper_force"] + [f"bushing_{channel.force}" for channel in BUSHING_CHANNELS.values()]
    laws = truth_laws(forces)
    graphs = {"truth-damper": damper_truth_graph(laws["damper_force"].truth, sample_period)}
    if with_bushing:
        truths = {key: laws[f"bushing_{channel.force}"].truth for key, channel in BUSHING_CHANNELS.items()}
        graphs["truth-bushing"] = bushing_truth_graph(truths, sample_period)
    built = {}
    for name, graph in graphs.items():
        with atomic_path(out / f"{name}.onnx") as tmp:
            onnx.save(graph, tmp)
        built[name] = build_fmu(out / f"{name}.onnx", BuildOptions(out=out / f"{name}.fmu"))
    return ComponentFmus({"truth": built["truth-damper"]}, built.get("truth-bushing"))


def vehicle_components(system: str) -> dict[str, str]:
    """Component choices of the road-test vehicle: dampers external, front LCA bushings stabilised."""
    return {name: STABILISED for name in bushing_elements(system)}


def build_vehicle(
    system: str,
    out: Path,
    step: float,
    stabilisers: Mapping[str, tuple[float, float]] | None = None,
    port_derivatives: bool = False,
) -> Path:
    """The vehicle FMU of `system` (`vehicle_components`) sampled at the communication `step` [s] (exact: every
    component is a port, so the vehicle is linear), starting where the monolithic reference does (`settled_state`);
    `stabilisers` replace the parameter file's elements of stabilised ports (`stabilisers.bushing_stabilisers`);
    `port_derivatives` gives those ports their stiffness and damping inputs (`VehicleBuildSettings`)."""
    components = vehicle_components(system)
    return build_vehicle_fmu(
        system,
        out / f"{system}.fmu",
        VehicleBuildSettings(
            components=components,
            sample_period=step,
            initial_state=settled_state(system, components),
            stabilisers=dict(stabilisers or {}),
            port_derivatives=port_derivatives and bool(components),
        ),
    )


def road_test_system(
    system: str,
    vehicle_fmu: Path,
    damper_fmu: Path,
    bushing_fmu: Path | None,
    filter_cutoff: float | None = None,
    cache: FmuCache | None = None,
) -> VirtualSystem:
    """The vehicle, its damper networks and (if `bushing_fmu` is given) its front LCA bushing FMUs joined by name,
    in memory; each network FMU's output low-pass set to `filter_cutoff` [Hz] (0: off; None: the FMUs' own default,
    nothing set); `cache`: what the FMUs carry, shared with the road test's other systems."""
    components = {name: damper_fmu for name in damper_elements(system)}
    if bushing_fmu is not None:
        components |= {name: bushing_fmu for name in bushing_elements(system)}
    parameters = {name: {"filter_cutoff": filter_cutoff} for name in components} if filter_cutoff is not None else {}
    label = f"{system} with {damper_fmu.stem}" + (" and LCA bushing networks" if bushing_fmu is not None else "")
    return VirtualSystem.by_name(label, ("vehicle", vehicle_fmu), components, parameters, cache)


def write_system(
    system: str,
    vehicle_fmu: Path,
    damper_fmu: Path,
    bushing_fmu: Path | None,
    folder: Path,
    filter_cutoff: float | None = None,
) -> Path:
    """`folder/SystemStructure.ssd` of `road_test_system` (its FMUs linked or copied into `folder`)."""
    return road_test_system(system, vehicle_fmu, damper_fmu, bushing_fmu, filter_cutoff).write(folder)
