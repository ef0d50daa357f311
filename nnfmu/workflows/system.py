"""A virtual system: an SSP system's structure with each element's FMU, and its component description and step graph
read from the FMU itself (once per FMU, checked against the digest its model description records); changed in
memory (an element's FMU swapped, parameter values set, the drive bound), co-simulated in memory through
`nnfmu.cosim`, and written as an SSD or SSP only when asked.

Use cases pass this object instead of system files, so a description is read once and no system is written only to
be reopened. In memory every element's FMU is named by its absolute path; `write` links or copies them into the
system's folder (SSD) or packs them into the archive (SSP), as `open_system` loads FMUs only from inside a system.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import onnx

from nnfmu.atomic import atomic_path, scratch_dir
from nnfmu.component import Component
from nnfmu.cosim import (
    SSD_NAME,
    CosimResult,
    CosimSettings,
    DriveBinding,
    Element,
    InstancePool,
    Progress,
    SystemStructure,
    check_against_fmus,
    connect_by_name,
    cosimulate,
    local_fmu,
    open_system,
    write_ssd,
)
from nnfmu.data import Measurement
from nnfmu.errors import NnfmuError
from nnfmu.fmu import StepGraphRecord, read_fmu_graph
from nnfmu.workflows.vehicle_binding import vehicle_binding

ROOT = Path("/")  # the base of an in-memory system: every element's source is its FMU's absolute path


class VirtualSystemError(NnfmuError, ValueError):
    """A change asked of a virtual system does not fit it; the message names the system, element and file."""


@dataclass(frozen=True)
class StepGraph:
    """What an FMU carries: its step graph's bytes and record (None: the FMU records none) and its component
    description."""

    data: bytes | None
    record: StepGraphRecord | None
    component: Component | None


@dataclass
class FmuCache:
    """Each FMU's step graph and description, read once per file version (path, size, modification time)."""

    found: dict[tuple[Path, int, int], StepGraph] = field(default_factory=dict)

    def read(self, fmu: Path) -> StepGraph:
        """The step graph and description `fmu` carries (StepGraphError for a record that is there but altered)."""
        stat = fmu.stat()
        key = (fmu, stat.st_size, stat.st_mtime_ns)
        if key not in self.found:
            data, record = read_fmu_graph(fmu) or (None, None)
            component = Component.from_onnx(onnx.load_from_string(data)) if data is not None else None
            self.found[key] = StepGraph(data, record, component)
        return self.found[key]

    def graph(self, fmu: Path) -> onnx.ModelProto | None:
        """The step graph `fmu` carries (a fresh copy); None: it records none."""
        data = self.read(fmu).data
        return onnx.load_from_string(data) if data is not None else None


@dataclass(frozen=True)
class VirtualSystem:
    """A system of FMUs in memory: the structure (every source an absolute FMU path), the drive binding (None: the
    vehicle's actuator inputs, `vehicle_binding`), and the shared cache of what the FMUs carry."""

    structure: SystemStructure
    binding: DriveBinding | None = None
    cache: FmuCache = field(default_factory=FmuCache, compare=False, repr=False)

    @classmethod
    def of(cls, structure: SystemStructure, cache: FmuCache | None = None) -> VirtualSystem:
        """The virtual system of a structure read from a file or built in memory, its FMUs named absolutely."""
        elements = [replace(e, source=str(structure.fmu_path(e).resolve())) for e in structure.elements]
        moved = replace(structure, elements=elements, base=ROOT)
        return cls(moved, None, cache if cache is not None else FmuCache())

    @classmethod
    @contextmanager
    def open(cls, path: str | os.PathLike[str] | VirtualSystem, allow_outside: bool = False) -> Iterator[VirtualSystem]:
        """The system of an `.ssd`, a folder holding one, or an `.ssp` (its FMUs valid inside the `with` only, as
        the archive's extracted copy is removed after it); checked as `open_system` checks it. A system already in
        memory is itself."""
        if isinstance(path, VirtualSystem):
            yield path
            return
        with open_system(path, allow_outside) as structure:
            yield cls.of(structure)

    @classmethod
    def by_name(
        cls,
        name: str,
        vehicle: tuple[str, Path],
        components: Mapping[str, Path],
        parameters: Mapping[str, Mapping[str, float]] | None = None,
        cache: FmuCache | None = None,
    ) -> VirtualSystem:
        """A vehicle and its components wired by name (`connect_by_name`'s rule), nothing written; `cache`: what
        the FMUs carry, shared with other systems of the same FMUs."""
        wired = connect_by_name(name, (vehicle[0], Path(vehicle[1]).resolve()), _absolute(components), ROOT, parameters)
        return cls.of(wired, cache)

    @property
    def name(self) -> str:
        """The system's name."""
        return self.structure.name

    @property
    def elements(self) -> list[str]:
        """The element names, in the system's order."""
        return [e.name for e in self.structure.elements]

    def element(self, name: str) -> Element:
        """The element `name` (SspError listing the elements where there is none)."""
        return self.structure.element(name)

    def fmu(self, element: str) -> Path:
        """The element's FMU (an absolute path)."""
        return Path(self.element(element).source)

    def parameters(self, element: str) -> dict[str, float]:
        """The element's parameter values set in the system."""
        return dict(self.element(element).parameters)

    def component(self, element: str) -> Component | None:
        """The component description the element's FMU carries in its step graph; None: the FMU records no graph."""
        return self.cache.read(self.fmu(element)).component

    def step_graph(self, element: str) -> onnx.ModelProto | None:
        """The step graph the element's FMU carries (a fresh copy); None: the FMU records none."""
        return self.cache.graph(self.fmu(element))

    def carried(self, element: str) -> StepGraph:
        """What the element's FMU carries: its step graph's bytes as stored, its record and its description."""
        return self.cache.read(self.fmu(element))

    def read_from(self, path: Path) -> VirtualSystem:
        """The system named as the file `path` it was written to (reports and messages name that file)."""
        return replace(self, structure=replace(self.structure, path=path))

    @property
    def where(self) -> Path:
        """The file the system was read from, for messages and reports (in memory only: `<its name>`)."""
        return self.structure.path or Path(f"<{self.name}>")

    def drive_binding(self) -> DriveBinding:
        """Which element's free inputs read which drive channels: the bound one, else the vehicle's actuators."""
        return self.binding if self.binding is not None else vehicle_binding(self.structure)

    def bind(self, binding: DriveBinding) -> VirtualSystem:
        """The system with the drive bound by `binding`."""
        self.element(binding.element)
        return replace(self, binding=binding)

    def swap(self, swaps: Mapping[str, str | os.PathLike[str]], rewire: bool = False, label: str = "") -> VirtualSystem:
        """The system with each element of `swaps` running the given FMU instead. Plain: connectors and connections
        stay (SspError where the new FMU lacks one); `rewire`: every element wired to the driven element again by
        name (`by_name`), so an FMU with a new port is connected by it. `label` is added to the system's name."""
        unknown = sorted(set(swaps) - set(self.elements))
        if unknown:
            raise VirtualSystemError(
                f"system {self.name!r}: no element {unknown} to swap (has: {', '.join(self.elements)})"
            )
        fmus = {e: Path(swaps[e]).resolve() if e in swaps else self.fmu(e) for e in self.elements}
        missing = [f"{e}: {p}" for e, p in fmus.items() if e in swaps and not p.is_file()]
        if missing:
            raise VirtualSystemError(f"system {self.name!r}: FMU(s) to swap in not found: {'; '.join(missing)}")
        name = f"{self.name} ({label})" if label else self.name
        if rewire:
            hub = self.drive_binding().element
            parameters = {e.name: dict(e.parameters) for e in self.structure.elements}
            others = {e: fmu for e, fmu in fmus.items() if e != hub}
            wired = connect_by_name(name, (hub, fmus[hub]), others, ROOT, parameters)
            times = {"start_time": self.structure.start_time, "stop_time": self.structure.stop_time}
            rewired = VirtualSystem.of(replace(wired, **times), self.cache)
            check_against_fmus(rewired.structure)
            return replace(rewired, binding=self.binding)
        elements = [replace(e, source=str(fmus[e.name])) for e in self.structure.elements]
        changed = replace(self.structure, name=name, elements=elements, path=None)
        check_against_fmus(changed)
        return replace(self, structure=changed)

    def with_parameters(self, values: Mapping[str, Mapping[str, float]]) -> VirtualSystem:
        """The system with the parameter values of `values` (element -> parameter -> value) set over its own."""
        unknown = sorted(set(values) - set(self.elements))
        if unknown:
            raise VirtualSystemError(
                f"system {self.name!r}: no element {unknown} to set (has: {', '.join(self.elements)})"
            )
        elements = [
            replace(e, parameters={**e.parameters, **values[e.name]}) if e.name in values else e
            for e in self.structure.elements
        ]
        changed = replace(self.structure, elements=elements, path=None)
        check_against_fmus(changed)
        return replace(self, structure=changed)

    def cosimulate(
        self,
        drive: Measurement,
        settings: CosimSettings,
        pool: InstancePool | None = None,
        progress: Progress | None = None,
    ) -> CosimResult:
        """The system co-simulated on `drive` in memory (`nnfmu.cosim.cosimulate`, its drive binding)."""
        return cosimulate(self.structure, drive, settings, progress, pool, self.drive_binding())

    def write(self, path: str | os.PathLike[str]) -> Path:
        """The system as `path`: an `.ssp` archive holding its FMUs, else `path` (a folder) / SystemStructure.ssd
        with every FMU outside that folder linked or copied into its `fmu/`; written atomically."""
        path = Path(path)
        if path.suffix.lower() == ".ssp":
            return self._write_ssp(path)
        path.mkdir(parents=True, exist_ok=True)
        return write_ssd(self._relative_to(path), path / SSD_NAME)

    def _relative_to(self, folder: Path) -> SystemStructure:
        """The structure with each FMU inside `folder` (`local_fmu`), named relative to it."""
        base = folder.resolve()
        elements = [
            replace(e, source=os.path.relpath(local_fmu(Path(e.source), base), base)) for e in self.structure.elements
        ]
        return replace(self.structure, elements=elements, base=folder, path=None)

    def _write_ssp(self, path: Path) -> Path:
        """An SSP archive: SystemStructure.ssd and each distinct FMU under `resources/`."""
        with scratch_dir("nnfmu-ssp-write-") as folder:
            names: dict[Path, str] = {}
            elements = []
            for e in self.structure.elements:
                fmu = Path(e.source)
                if fmu not in names:
                    taken = set(names.values())
                    member = f"resources/{fmu.name}"
                    for n in range(2, len(names) + 3):
                        if member not in taken:
                            break
                        member = f"resources/{fmu.stem}-{n}{fmu.suffix}"
                    names[fmu] = member
                elements.append(replace(e, source=names[fmu]))
            ssd = write_ssd(replace(self.structure, elements=elements, base=folder, path=None), Path(folder) / SSD_NAME)
            path.parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as archive:
                archive.write(ssd, SSD_NAME)
                for fmu, member in names.items():
                    archive.write(fmu, member)
        return path


def _absolute(components: Mapping[str, str | os.PathLike[str]]) -> dict[str, Path]:
    """Each component's FMU as an absolute path."""
    return {name: Path(fmu).resolve() for name, fmu in components.items()}
