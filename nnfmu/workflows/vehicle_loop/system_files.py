"""The virtual car's files: its SSP system, the vehicle element, each component element's FMU and ONNX step graph,
and a copy of the system with some elements' FMUs swapped (wired again by name, as the road test wires them).

An element's step graph is the one its FMU carries (`nnfmu.fmu.step_graph`), checked against the digest its model
description records. `--model ELEMENT=ONNX` overrides it only with the same network (else refused); an ONNX beside
the FMU that is another network is ignored, loudly. An FMU that records no graph (another tool's, an older nnfmu's)
takes the given or the beside ONNX unverified, said in the notes."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import onnx

from nnfmu.cosim import connect_by_name, open_system, write_ssd
from nnfmu.fmu import StepGraphError, check_same_graph, extract_fmu_graph
from nnfmu.input_files import not_regular
from nnfmu.kinds import ComponentKind, kind_of
from nnfmu.workflows.vehicle_binding import vehicle_binding
from nnfmu.workflows.vehicle_loop.settings import VehicleLoopError


@dataclass(frozen=True)
class VirtualCar:
    """The system file, its vehicle element and FMU, every component element's FMU and step graph (None where no
    ONNX file is known), the elements' parameter values, and what was said about where each graph came from."""

    ssd: Path
    name: str
    vehicle: str
    vehicle_fmu: Path
    fmus: dict[str, Path]
    onnx: dict[str, Path | None]
    parameters: dict[str, dict[str, float]]
    graph_notes: tuple[str, ...] = ()

    def kind(self, element: str) -> ComponentKind | None:
        """The element's component kind, from its name (the road test's naming, `nnfmu.kinds`); None: no kind's."""
        return kind_of(element)


def read_virtual_car(
    ssd: str | Path,
    graphs: Path,
    models: Mapping[str, str | Path] | None = None,
    log: Callable[[str], None] = print,
    allow_outside: bool = False,
) -> VirtualCar:
    """The virtual car of `ssd`, each element's step graph read from its FMU into `graphs/<element>.onnx` (module
    docstring); `models` maps element names to ONNX step graphs that override them. VehicleLoopError for a system
    without a vehicle element, a given graph that is not its FMU's network, or an FMU whose graph was altered;
    SspError for one with FMUs outside its folder unless `allow_outside`."""
    models = {k: Path(v) for k, v in (models or {}).items()}
    with open_system(ssd, allow_outside) as system:
        binding = vehicle_binding(system)
        if not any(n.startswith("actuator_") for n in binding.inputs):
            raise VehicleLoopError(f"{ssd}: no element with a four-poster's actuator inputs (a vehicle FMU)")
        fmus = {e.name: system.fmu_path(e).resolve() for e in system.elements if e.name != binding.element}
        unknown = sorted(set(models) - set(fmus))
        if unknown:
            raise VehicleLoopError(f"{ssd}: --model names no element {unknown} (elements: {', '.join(fmus)})")
        notes: list[str] = []
        onnx = {e: _step_graph(e, fmu, models.get(e), graphs, notes) for e, fmu in fmus.items()}
        for note in notes:
            log(f"warning: {note}")
        return VirtualCar(
            ssd=Path(system.path or ssd),
            name=system.name,
            vehicle=binding.element,
            vehicle_fmu=system.fmu_path(binding.element).resolve(),
            fmus=fmus,
            onnx=onnx,
            parameters={e.name: dict(e.parameters) for e in system.elements},
            graph_notes=tuple(notes),
        )


def _readable(element: str, path: Path) -> None:
    """VehicleLoopError naming the element and file when `path` is no ONNX model."""
    try:
        onnx.load(str(path))
    except Exception as err:  # onnx raises DecodeError, OSError or its own errors
        raise VehicleLoopError(f"ONNX file of element {element!r} {path}: cannot read the ONNX model: {err}") from None


def _step_graph(element: str, fmu: Path, given: Path | None, graphs: Path, notes: list[str]) -> Path | None:
    """The element's step graph: given (checked against the FMU's record where it has one), else the FMU's own,
    else an ONNX beside an FMU without a record; what cannot be verified or is ignored goes into `notes`."""
    if given is not None and not given.is_file():
        why = not_regular(given) or ("is a folder" if given.is_dir() else "not found")
        raise VehicleLoopError(f"ONNX file of element {element!r} {given}: {why}")
    try:
        record = extract_fmu_graph(fmu, graphs / f"{element}.onnx")
    except StepGraphError as err:
        raise VehicleLoopError(f"element {element!r}: {err}; rebuild its FMU with nnfmu build") from None
    beside = fmu.with_suffix(".onnx")
    if record is None:
        found = given or (beside if beside.is_file() else None)
        if found is not None:
            _readable(element, found)
            notes.append(
                f"{element}: its FMU {fmu.name} records no step graph (another tool's or an older nnfmu's), so "
                f"{found} cannot be checked to be its network; rebuild the FMU with nnfmu build to bind them"
            )
        return found
    if given is not None:
        _readable(element, given)
        try:
            check_same_graph(given, record, fmu)
        except StepGraphError as err:
            raise VehicleLoopError(f"--model {element}={given}: {err}; refusing to diagnose another network") from None
        return given
    if beside.is_file():
        try:
            check_same_graph(beside, record, fmu)
        except StepGraphError as err:
            notes.append(f"{element}: ignored {beside}: {err}; the step graph the FMU carries is used")
    return graphs / f"{element}.onnx"


def swapped_system(car: VirtualCar, swaps: Mapping[str, Path], folder: Path, label: str) -> Path:
    """`folder/SystemStructure.ssd`: the car with the FMUs of `swaps` (element -> FMU) in those elements' places,
    every element wired to the vehicle by name (an FMU with a new input, a damper reading its displacement, is
    connected to the vehicle's output of that name)."""
    components = {name: Path(swaps.get(name, fmu)) for name, fmu in car.fmus.items()}
    folder.mkdir(parents=True, exist_ok=True)
    structure = connect_by_name(
        f"{car.name} ({label})", (car.vehicle, car.vehicle_fmu), components, folder, car.parameters
    )
    return write_ssd(structure, folder / "SystemStructure.ssd")
