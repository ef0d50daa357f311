"""Sensitivity of the vehicle's channels to one basis term of a component's candidate effect, measured in the
co-simulation: the element's network with the term added (`nnfmu.export.terms`), built as an FMU, swapped into the
system and replayed on the lab's drive; the change of every channel divided by the term's coefficient."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import onnx

from nnfmu.atomic import atomic_path
from nnfmu.data import Measurement
from nnfmu.export.terms import OutputTerm, add_output_terms
from nnfmu.fmu import BuildOptions, build_fmu
from nnfmu.kinds import BUSHING, KindChannel
from nnfmu.workflows.system import VirtualSystem
from nnfmu.workflows.vehicle_loop.system_files import VirtualCar

Replay = Callable[[VirtualSystem], Measurement]  # a system -> its channels on the record's time stamps
PERTURBATION = 0.1  # a bushing's stiffness sensitivity is measured 10 % stiffer than its network: small enough for
# first order, large enough to stand out of the co-simulation's numerical noise (a joint effect's step)


def network_stiffness(
    replay: Measurement, element: str, channels: Sequence[KindChannel] = BUSHING.channels
) -> dict[str, float]:
    """The element's own stiffness per channel of its kind (force or torque output -> N/m or N.m/rad): the
    least-squares fit F = k x + c v + F0 of its network's output on its deflection (or rotation) and rate along the
    virtual car's replay `replay`; channels the replay lacks or whose fitted k is not positive are left out."""
    rates = {}
    for ch in channels:
        names = [f"{element}_{n}" for n in (ch.position, ch.rate, ch.force)]
        if not all(n in replay for n in names):
            continue
        x, v, force = (np.asarray(replay[n], dtype=float) for n in names)
        design = np.column_stack([x, v, np.ones_like(x)])
        if not np.all(np.isfinite(design)) or np.linalg.matrix_rank(design) < 3:
            continue
        stiffness = float(np.linalg.lstsq(design, force, rcond=None)[0][0])
        if np.isfinite(stiffness) and stiffness > 0:
            rates[ch.force] = stiffness
    return rates


def term_fmu(source: Path, terms: tuple[OutputTerm, ...], out: Path, label: str) -> tuple[Path, Path]:
    """The step graph `source` with `terms` added, as `out.onnx` and the FMU `out.fmu` (this machine's binaries);
    returns both paths (graph, FMU)."""
    graph = add_output_terms(onnx.load(source), terms, f"{label}: {source.name} with added physical terms")
    onnx_path = out.with_suffix(".onnx")
    with atomic_path(onnx_path) as tmp:
        onnx.save(graph, tmp)
    return onnx_path, build_fmu(onnx_path, BuildOptions(out=out.with_suffix(".fmu"), platforms=("linux64",)))


class Sensitivities:
    """Builds each (step graph, terms) FMU once in `folder` and replays each (element, terms) swap once, in memory."""

    def __init__(self, car: VirtualCar, folder: Path, replay: Replay, base: Measurement, channels: list[str]) -> None:
        self.car, self.folder, self.replay, self.base, self.channels = car, folder, replay, base, channels
        self._fmus: dict[tuple[Path, tuple[OutputTerm, ...]], Path] = {}

    def _fmu(self, source: Path, terms: tuple[OutputTerm, ...]) -> Path:
        key = (source, terms)
        if key not in self._fmus:
            name = f"{source.stem}-term{len(self._fmus)}"
            self._fmus[key] = term_fmu(source, terms, self.folder / "fmu" / name, "sensitivity")[1]
        return self._fmus[key]

    def _change(self, element: str, terms: tuple[OutputTerm, ...], label: str, per: float) -> np.ndarray:
        """The (n, C) change of the channels with `terms` added to `element`, divided by `per`."""
        source = self.car.onnx[element]
        assert source is not None
        moved = self.replay(self.car.swapped({element: self._fmu(source, terms)}, label))
        return np.column_stack([(moved[c] - self.base[c]) / per for c in self.channels])

    def columns(self, element: str, terms: tuple[OutputTerm, ...], joint_step: float | None = None) -> list[np.ndarray]:
        """Per term, the (n, C) change of the channels per unit coefficient with it added to `element`; with
        `joint_step`, one column: all terms added at `joint_step` times their coefficients, per unit amplitude."""
        if joint_step is not None:
            scaled = tuple(OutputTerm(t.output, t.channel, joint_step * t.coefficient, t.unit) for t in terms)
            return [self._change(element, scaled, "joint", joint_step)]
        return [self._change(element, (t,), f"term{i}", t.coefficient) for i, t in enumerate(terms)]
