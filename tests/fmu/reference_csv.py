"""Stored reference runs of tiny step graphs, like the Reference-FMUs' `<Model>_in.csv` / `<Model>_out.csv`: the
inputs a master sets (row n before step n, row 0 at initialisation) and the outputs onnxruntime's step-by-step
evaluation of the graph gives under the FMU semantics at default parameters (row n after step n).

The graphs come from fixed recipes (`native_fmu_helpers`), the inputs from a seeded generator; the outputs were
computed once with onnxruntime and committed under `reference/`. Regenerate them (only after a deliberate change of a
recipe) with `python tests/fmu/reference_csv.py`.
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx
from native_fmu_helpers import SAMPLE_PERIOD, Reference, delay_step_graph, generic_graph

FOLDER = Path(__file__).parent / "reference"
ROWS = 41  # communication points: initialisation and 40 steps


@dataclass(frozen=True)
class Recipe:
    """A tiny graph, the communication step of its run and the seed of its inputs."""

    graph: Callable[[], onnx.ModelProto]
    step: float  # [s]
    seed: int

    def inputs(self) -> np.ndarray:
        """Inputs in [-0.9, 0.9] (inside the training envelope of every port that has one, scaled per port)."""
        reference = Reference(self.graph())
        scale = [0.9 * (p.max if p.max is not None else 1.0) for p in reference.component.inputs]
        return np.random.default_rng(self.seed).uniform(-1, 1, (ROWS, len(scale))) * np.array(scale)


RECIPES = {
    "delay_damper": Recipe(delay_step_graph, 2.5 * SAMPLE_PERIOD, seed=1),  # delay-line state, two samples per step
    "other_tool": Recipe(generic_graph, 0.01, seed=2),  # no metadata, no sample period: one evaluation per step
}


def port_names(graph: onnx.ModelProto) -> tuple[list[str], list[str]]:
    """The FMU variable names of the graph's input and output ports (the sanitised names of the description)."""
    from nnfmu.fmu.variables import fmu_variables

    reference = Reference(graph)
    variables = fmu_variables(reference.component)
    return [v.name for v in variables.inputs], [v.name for v in variables.outputs]


def expected_outputs(name: str, inputs: np.ndarray) -> np.ndarray:
    """onnxruntime's outputs for `inputs` under the FMU semantics at default parameters (filter off, gain 1)."""
    recipe = RECIPES[name]
    return Reference(recipe.graph()).simulate(inputs, recipe.step)


def read(path: Path) -> tuple[list[str], np.ndarray]:
    """Header (after `time`) and values (rows x columns, `time` dropped) of a stored CSV."""
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    return rows[0][1:], np.array([[float(x) for x in row[1:]] for row in rows[1:]])


def write(path: Path, names: list[str], step: float, values: np.ndarray) -> None:
    """`time,<names>` and one row per communication point, numbers written to round-trip."""
    with path.open("w", newline="", encoding="utf-8") as handle:
        out = csv.writer(handle, lineterminator="\n")
        out.writerow(["time", *names])
        for n, row in enumerate(values):
            out.writerow([repr(n * step), *(repr(float(x)) for x in row)])


def main() -> None:
    FOLDER.mkdir(exist_ok=True)
    for name, recipe in RECIPES.items():
        inputs = recipe.inputs()
        input_names, output_names = port_names(recipe.graph())
        write(FOLDER / f"{name}_in.csv", input_names, recipe.step, inputs)
        write(FOLDER / f"{name}_out.csv", output_names, recipe.step, expected_outputs(name, inputs))


if __name__ == "__main__":
    main()
