"""The virtual car: its system (`VirtualSystem`: every element's FMU, and the step graph and description it carries,
read once per FMU), its vehicle element, and each component element's step graph as an ONNX file for the component
loop and the physical terms.

An element's step graph is the one its FMU carries (`nnfmu.fmu.step_graph`), checked against the digest its model
description records. `--model ELEMENT=ONNX` overrides it only with the same network (else refused). An FMU that
records no graph (another tool's, an older nnfmu's) takes a given ONNX unverified, said in the notes; without one
its effects are not tested. No ONNX is looked for by its file name."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import onnx

from nnfmu.fmu import StepGraphError, check_same_graph
from nnfmu.input_files import not_regular
from nnfmu.kinds import ComponentKind, kind_of
from nnfmu.workflows.system import VirtualSystem
from nnfmu.workflows.vehicle_loop.settings import VehicleLoopError


@dataclass(frozen=True)
class VirtualCar:
    """The system (read from `ssd`), its vehicle element, every component element's step graph as an ONNX file (None
    where none is known), and what was said about where each graph came from."""

    ssd: Path
    system: VirtualSystem
    vehicle: str
    onnx: dict[str, Path | None]
    graph_notes: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        """The system's name."""
        return self.system.name

    @property
    def fmus(self) -> dict[str, Path]:
        """Every component element's FMU (all elements but the vehicle), in the system's order."""
        return {e: self.system.fmu(e) for e in self.system.elements if e != self.vehicle}

    @property
    def vehicle_fmu(self) -> Path:
        """The vehicle element's FMU."""
        return self.system.fmu(self.vehicle)

    def kind(self, element: str) -> ComponentKind | None:
        """The element's component kind, from its name (the road test's naming, `nnfmu.kinds`); None: no kind's."""
        return kind_of(element)

    def swapped(self, swaps: Mapping[str, Path], label: str) -> VirtualSystem:
        """The car with the FMUs of `swaps` (element -> FMU) in those elements' places, every element wired to the
        vehicle by name (an FMU with a new input, a damper reading its displacement, is connected to the vehicle's
        output of that name)."""
        return self.system.swap(swaps, rewire=True, label=label)


def read_virtual_car(
    system: VirtualSystem,
    ssd: Path,
    graphs: Path,
    models: Mapping[str, str | Path] | None = None,
    log: Callable[[str], None] = print,
) -> VirtualCar:
    """The virtual car of `system` (read from `ssd`), each element's step graph written from its FMU's into
    `graphs/<element>.onnx` (module docstring); `models` maps element names to ONNX step graphs that override them.
    VehicleLoopError for a system without a vehicle element, a given graph that is not its FMU's network, or an FMU
    whose graph was altered."""
    models = {k: Path(v) for k, v in (models or {}).items()}
    binding = system.drive_binding()
    if not any(n.startswith("actuator_") for n in binding.inputs):
        raise VehicleLoopError(f"{ssd}: no element with a four-poster's actuator inputs (a vehicle FMU)")
    elements = [e for e in system.elements if e != binding.element]
    unknown = sorted(set(models) - set(elements))
    if unknown:
        raise VehicleLoopError(f"{ssd}: --model names no element {unknown} (elements: {', '.join(elements)})")
    notes: list[str] = []
    onnx = {e: _step_graph(system, e, models.get(e), graphs, notes) for e in elements}
    for note in notes:
        log(f"warning: {note}")
    return VirtualCar(ssd, system.bind(binding), binding.element, onnx, tuple(notes))  # bound once for every replay


def _readable(element: str, path: Path) -> None:
    """VehicleLoopError naming the element and file when `path` is no ONNX model."""
    try:
        onnx.load(str(path))
    except Exception as err:  # onnx raises DecodeError, OSError or its own errors
        raise VehicleLoopError(f"ONNX file of element {element!r} {path}: cannot read the ONNX model: {err}") from None


def _step_graph(system: VirtualSystem, element: str, given: Path | None, graphs: Path, notes: list[str]) -> Path | None:
    """The element's step graph: given (checked against the FMU's record where it has one), else the FMU's own;
    a given graph that cannot be verified goes into `notes`."""
    fmu = system.fmu(element)
    if given is not None and not given.is_file():
        why = not_regular(given) or ("is a folder" if given.is_dir() else "not found")
        raise VehicleLoopError(f"ONNX file of element {element!r} {given}: {why}")
    try:
        carried = system.carried(element)
    except StepGraphError as err:
        raise VehicleLoopError(f"element {element!r}: {err}; rebuild its FMU with nnfmu build") from None
    if carried.record is None or carried.data is None:
        if given is not None:
            _readable(element, given)
            notes.append(
                f"{element}: its FMU {fmu.name} records no step graph (another tool's or an older nnfmu's), so "
                f"{given} cannot be checked to be its network; rebuild the FMU with nnfmu build to bind them"
            )
        return given
    if given is not None:
        _readable(element, given)
        try:
            check_same_graph(given, carried.record, fmu)
        except StepGraphError as err:
            raise VehicleLoopError(f"--model {element}={given}: {err}; refusing to diagnose another network") from None
        return given
    target = graphs / f"{element}.onnx"
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(carried.data)
    return target
