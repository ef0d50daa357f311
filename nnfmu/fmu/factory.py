"""The FMU factory's front half, shared by every backend: an in-memory graph, its component and the build options
become one `BuildPlan` (identifier, output path, variables, dependencies), and `assemble` runs a backend on a
temporary folder, adds the reference results and zips the `.fmu` atomically.

A backend is a function `(plan, tree) -> None` that writes only what differs between backends into the FMU folder
`tree`: modelDescription.xml with its own instantiation token (the view comes from the plan), and its sources and
compiled binaries (native) or its resources and runtime (pythonfmu). The front half writes the graph with its
component description at `extra/org.nnfmu/model.onnx` and the view carries its digests into the model description
(`step_graph.py`), so every FMU nnfmu writes carries its own step graph. Every failure is an FmuBuildError naming the
source (the ONNX file, or the in-memory graph); no `.fmu` is written then.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import onnx

from nnfmu.atomic import scratch_dir
from nnfmu.component import Component
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.model_description import FmuIdentity, ModelDescriptionView, tensor_dependencies
from nnfmu.fmu.names import c_identifier
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.package import package_fmu
from nnfmu.fmu.reference_results import write_reference_results
from nnfmu.fmu.step_graph import EmbeddedGraph, embedded_graph, write_embedded_graph
from nnfmu.fmu.variables import FmuVariables, fmu_variables
from nnfmu.input_files import not_regular


@dataclass(frozen=True)
class BuildPlan:
    """What every backend builds from: the graph (a private copy), its component, the options, where the graph came
    from (`source` names it in errors, `source_name` is the short form in generated comments), the model identifier,
    the `.fmu` path, the FMU variables with their graph dependencies and the graph as the FMU carries it."""

    model: onnx.ModelProto
    component: Component
    options: BuildOptions
    source: str
    source_name: str
    identifier: str
    target: Path
    variables: FmuVariables
    dependencies: dict[str, set[str]]
    graph: EmbeddedGraph

    @property
    def fmi_version(self) -> int:
        return self.options.fmi_version

    def view(
        self, token: str, source_files: Sequence[str] = (), directional_derivatives: bool = False
    ) -> ModelDescriptionView:
        """What the modelDescription templates read, with the backend's instantiation token, C sources and whether
        its binaries provide directional derivatives."""
        identity = FmuIdentity(self.component.name, self.identifier, token, self.fmi_version)
        return ModelDescriptionView(
            identity,
            self.component,
            self.variables,
            self.dependencies,
            list(source_files),
            directional_derivatives,
            self.graph.record,
        )


Backend = Callable[[BuildPlan, Path], None]


def default_output(stem: str) -> Path:
    """Where an FMU named `stem` goes when no `--out` is given (`nnfmu build` names it after its ONNX file; a graph
    built in memory after its model identifier)."""
    return Path("exported") / f"{stem}.fmu"


def load_onnx(onnx_path: Path) -> onnx.ModelProto:
    """Read an ONNX file, naming it in the error when it is missing or cannot be read."""
    if not Path(onnx_path).is_file():
        raise FmuBuildError(f"{onnx_path}: {not_regular(Path(onnx_path)) or 'no such ONNX file'}")
    try:
        return onnx.load(str(onnx_path))
    except Exception as err:  # onnx raises DecodeError, OSError or its own errors
        raise FmuBuildError(f"{onnx_path}: cannot read the ONNX model: {err}") from err


def in_memory_source(model: onnx.ModelProto) -> str:
    """How errors and generated comments name a graph that was never a file."""
    return f"ONNX graph {model.graph.name!r} (in memory)"


def plan_build(
    model: onnx.ModelProto,
    options: BuildOptions,
    component: Component | None = None,
    source: str | None = None,
    source_name: str | None = None,
) -> BuildPlan:
    """Derive everything the backends share, once: the component (given, or read from the graph's metadata, with the
    options' name and filter start value), identifier, output path, variables and dependencies. The graph is copied,
    so a backend may attach metadata to its copy without touching the caller's."""
    source = source or in_memory_source(model)
    private = onnx.ModelProto()
    private.CopyFrom(model)
    described = options.describe(component) if component is not None else options.component_of(private, source)
    identifier = c_identifier(described.name)
    target = Path(options.out) if options.out is not None else default_output(identifier)
    return BuildPlan(
        private,
        described,
        options,
        source,
        source_name or source,
        identifier,
        target,
        fmu_variables(described),
        tensor_dependencies(private),
        embedded_graph(private, described),
    )


def assemble(plan: BuildPlan, backend: Backend) -> Path:
    """Run `backend` on a temporary FMU folder, add the step graph and the reference results and zip it to
    `plan.target`."""
    with scratch_dir("nnfmu-build-") as tmp:
        tree = Path(tmp) / "fmu"
        tree.mkdir()
        backend(plan, tree)
        write_embedded_graph(tree, plan.graph)
        write_reference_results(tree, plan.model, plan.component, plan.variables)
        return package_fmu(tree, plan.target)
