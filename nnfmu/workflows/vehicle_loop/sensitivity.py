"""Sensitivity of the vehicle's channels to one basis term of a component's candidate effect, measured in the
co-simulation: the element's network with the term added (`nnfmu.export.terms`), built as an FMU, swapped into the
system and replayed on the lab's drive; the change of every channel divided by the term's coefficient."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import onnx

from nnfmu.atomic import atomic_path
from nnfmu.data import Measurement
from nnfmu.export.terms import OutputTerm, add_output_terms
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.workflows.vehicle_loop.system_files import VirtualCar, swapped_system

Replay = Callable[[Path], Measurement]  # an SSD -> its channels on the record's time stamps


def term_fmu(source: Path, terms: tuple[OutputTerm, ...], out: Path, label: str) -> Path:
    """The step graph `source` with `terms` added, as `out.onnx` and the FMU `out.fmu` (this machine's binaries)."""
    graph = add_output_terms(onnx.load(source), terms, f"{label}: {source.name} with added physical terms")
    with atomic_path(out.with_suffix(".onnx")) as tmp:
        onnx.save(graph, tmp)
    return build_fmu(out.with_suffix(".onnx"), BuildOptions(out=out.with_suffix(".fmu"), platforms=("linux64",)))


class Sensitivities:
    """Builds each (step graph, term) FMU once and replays each (element, term) swap once, in `folder`."""

    def __init__(self, car: VirtualCar, folder: Path, replay: Replay, base: Measurement, channels: list[str]) -> None:
        self.car, self.folder, self.replay, self.base, self.channels = car, folder, replay, base, channels
        self._fmus: dict[tuple[Path, OutputTerm], Path] = {}

    def _fmu(self, source: Path, term: OutputTerm) -> Path:
        key = (source, term)
        if key not in self._fmus:
            name = f"{source.stem}-term{len(self._fmus)}"
            self._fmus[key] = term_fmu(source, (term,), self.folder / "fmu" / name, "sensitivity")
        return self._fmus[key]

    def columns(self, element: str, terms: tuple[OutputTerm, ...]) -> list[np.ndarray]:
        """Per term, the (n, C) change of the channels per unit coefficient with it added to `element`."""
        source = self.car.onnx[element]
        assert source is not None
        found = []
        for i, term in enumerate(terms):
            ssd = swapped_system(
                self.car, {element: self._fmu(source, term)}, self.folder / f"{element}-term{i}", "sensitivity"
            )
            moved = self.replay(ssd)
            found.append(np.column_stack([(moved[c] - self.base[c]) / term.coefficient for c in self.channels]))
        return found
