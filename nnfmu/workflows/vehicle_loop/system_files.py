"""The virtual car's files: its SSP system, the vehicle element, each component element's FMU and ONNX step graph,
and a copy of the system with some elements' FMUs swapped (wired again by name, as the road test wires them)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.workflows.vehicle_binding import vehicle_binding
from nnfmu.workflows.vehicle_loop.settings import VehicleLoopError


@dataclass(frozen=True)
class VirtualCar:
    """The system file, its vehicle element and FMU, every component element's FMU and step graph (None where no
    ONNX file is known), and the elements' parameter values."""

    ssd: Path
    name: str
    vehicle: str
    vehicle_fmu: Path
    fmus: dict[str, Path]
    onnx: dict[str, Path | None]
    parameters: dict[str, dict[str, float]]

    def kind(self, element: str) -> str:
        """'damper', 'bushing' or 'other', from the element's name (the road test's naming)."""
        return next((k for k in ("damper", "bushing") if element.startswith(k)), "other")


def read_virtual_car(
    ssd: str | Path, models: Mapping[str, str | Path] | None = None, allow_outside: bool = False
) -> VirtualCar:
    """The virtual car of `ssd`; `models` maps element names to their ONNX step graphs, else `<fmu stem>.onnx` beside
    an element's FMU is used where it exists. VehicleLoopError for a system without a vehicle element; SspError for
    one with FMUs outside its folder unless `allow_outside`."""
    models = {k: Path(v) for k, v in (models or {}).items()}
    with open_system(ssd, allow_outside) as system:
        binding = vehicle_binding(system)
        if not any(n.startswith("actuator_") for n in binding.inputs):
            raise VehicleLoopError(f"{ssd}: no element with a four-poster's actuator inputs (a vehicle FMU)")
        fmus = {e.name: system.fmu_path(e).resolve() for e in system.elements if e.name != binding.element}
        unknown = sorted(set(models) - set(fmus))
        if unknown:
            raise VehicleLoopError(f"{ssd}: --model names no element {unknown} (elements: {', '.join(fmus)})")
        onnx = {}
        for element, fmu in fmus.items():
            beside = fmu.with_suffix(".onnx")
            onnx[element] = models.get(element) or (beside if beside.is_file() else None)
            if onnx[element] is not None and not onnx[element].is_file():
                raise VehicleLoopError(f"{ssd}: ONNX file of element {element!r} not found: {onnx[element]}")
        return VirtualCar(
            ssd=Path(system.path or ssd),
            name=system.name,
            vehicle=binding.element,
            vehicle_fmu=system.fmu_path(binding.element).resolve(),
            fmus=fmus,
            onnx=onnx,
            parameters={e.name: dict(e.parameters) for e in system.elements},
        )


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
