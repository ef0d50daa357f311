"""Render modelDescription.xml (FMI 2.0 or 3.0 co-simulation) from a component's FMU variables.

The XML comes from jinja2 templates in `templates/` with autoescaping on, so any name or description from an ONNX
file is escaped; control characters XML cannot carry are dropped. Units are de-duplicated into `UnitDefinitions`
with SI base-unit exponents for the units nnfmu uses. The `ModelStructure` follows docs/fmu.md: at a communication
point an output of a sampled FMU depends on no input (outputs change only in doStep), while an interpolating FMU's
outputs depend on the inputs their graph tensor is computed from (inputs set there are the latest sample's); at
initialisation every output depends on those inputs and on `output_gain`.
"""

from __future__ import annotations

import functools
import hashlib
import uuid
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import cached_property

import jinja2
import onnx

import nnfmu
from nnfmu.component import Component
from nnfmu.fmu.names import xml_text
from nnfmu.fmu.sampling import ANNOTATION_TOOL
from nnfmu.fmu.step_graph import ANNOTATION_TOOL as STEP_GRAPH_TOOL
from nnfmu.fmu.step_graph import StepGraphRecord
from nnfmu.fmu.variables import FmuVariable, FmuVariables
from nnfmu.resources import templates_dir

GENERATION_TOOL = f"nnfmu {nnfmu.__version__}"
# An unknown that depends on more knowns than this has no `dependencies` attribute, which FMI 2 and 3 define as
# "depends on every known" (a superset): listing them would make the XML grow with inputs x outputs.
MAX_LISTED_DEPENDENCIES = 100

# SI base-unit exponents (FMI BaseUnit attributes) of the units nnfmu writes.
SI_EXPONENTS: dict[str, tuple[tuple[str, int], ...]] = {
    "1": (),
    "m": (("m", 1),),
    "m/s": (("m", 1), ("s", -1)),
    "m/s^2": (("m", 1), ("s", -2)),
    "N": (("kg", 1), ("m", 1), ("s", -2)),
    "N.m": (("kg", 1), ("m", 2), ("s", -2)),
    "Pa": (("kg", 1), ("m", -1), ("s", -2)),
    "rad": (("rad", 1),),
    "rad/s": (("rad", 1), ("s", -1)),
    "rad/s^2": (("rad", 1), ("s", -2)),
    "K": (("K", 1),),
    "s": (("s", 1),),
    "Hz": (("s", -1),),
    "kg": (("kg", 1),),
    "V": (("kg", 1), ("m", 2), ("s", -3), ("A", -1)),
    "A": (("A", 1),),
}


@dataclass(frozen=True)
class UnitDefinition:
    """One `<Unit>`: its name and SI exponents, or `None` for a unit nnfmu does not know (listed without BaseUnit)."""

    name: str
    exponents: tuple[tuple[str, int], ...] | None


@dataclass(frozen=True)
class FmuIdentity:
    """What names an FMU: model name, C model identifier (names the binary), instantiation token, FMI version."""

    model_name: str
    identifier: str
    token: str
    fmi_version: int


def instantiation_token(onnx_bytes: bytes, component: Component, fmi_version: int) -> str:
    """A GUID-shaped token derived from the graph, its description and the FMI version (same input, same token)."""
    digest = hashlib.sha256()
    for part in (onnx_bytes, component.to_json().encode(), f"{GENERATION_TOOL} fmi{fmi_version}".encode()):
        digest.update(hashlib.sha256(part).digest())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=4)) + "}"


def unit_definitions(variables: Iterable[FmuVariable]) -> list[UnitDefinition]:
    """The distinct units of `variables`, in order of first use."""
    seen: dict[str, UnitDefinition] = {}
    for v in variables:
        if v.unit and v.unit not in seen:
            seen[v.unit] = UnitDefinition(v.unit, SI_EXPONENTS.get(v.unit))
    return list(seen.values())


def tensor_dependencies(model: onnx.ModelProto) -> dict[str, set[str]]:
    """For every graph output tensor, the graph input tensors it is computed from (walking nodes backwards, without
    recursion: a chain of thousands of nodes is fine)."""
    producers = {out: node for node in model.graph.node for out in node.output}
    graph_inputs = {vi.name for vi in model.graph.input}
    dependencies: dict[str, set[str]] = {}
    for output in model.graph.output:
        found: set[str] = set()
        seen = {output.name}
        pending = [output.name]
        while pending:
            tensor = pending.pop()
            if tensor in graph_inputs:
                found.add(tensor)
                continue
            node = producers.get(tensor)
            if node is None:
                continue
            if any(attribute.g.node or attribute.graphs for attribute in node.attribute):
                found = set(graph_inputs)  # subgraphs (If/Loop/Scan) may read outer tensors: be conservative
                break
            for name in node.input:
                if name and name not in seen:
                    seen.add(name)
                    pending.append(name)
        dependencies[output.name] = found
    return dependencies


@dataclass
class ModelDescriptionView:
    """Everything the modelDescription templates read, with small helpers for the attributes that need rules."""

    identity: FmuIdentity
    component: Component
    fmu_variables: FmuVariables
    dependencies: dict[str, set[str]]
    source_files: list[str] = field(default_factory=list)
    directional_derivatives: bool = False  # the binaries compute d(outputs)/d(inputs) (native, graph with tangents)
    step_graph: StepGraphRecord | None = None

    @property
    def model_name(self) -> str:
        return xml_text(self.identity.model_name)

    @property
    def identifier(self) -> str:
        return self.identity.identifier

    @property
    def token(self) -> str:
        return self.identity.token

    @property
    def description(self) -> str:
        return xml_text(self.component.description)

    @property
    def generation_tool(self) -> str:
        return GENERATION_TOOL

    @property
    def sample_period(self) -> float | None:
        return self.component.sample_period

    @property
    def annotation_tool(self) -> str:
        return ANNOTATION_TOOL

    @property
    def step_graph_tool(self) -> str:
        return STEP_GRAPH_TOOL

    @cached_property
    def variables(self) -> list[FmuVariable]:
        return [self._clean(v) for v in self.fmu_variables.listed(self.identity.fmi_version)]

    @cached_property
    def outputs(self) -> list[FmuVariable]:
        return [self._clean(v) for v in (*self.fmu_variables.outputs, self.fmu_variables.extrapolating)]

    @property
    def units(self) -> list[UnitDefinition]:
        return unit_definitions(self.fmu_variables.listed(self.identity.fmi_version))

    @staticmethod
    def _clean(v: FmuVariable) -> FmuVariable:
        return FmuVariable(
            v.name,
            v.value_reference,
            v.causality,
            v.type,
            xml_text(v.unit),
            xml_text(v.description),
            v.start,
            v.port_index,
        )

    @staticmethod
    def variability(v: FmuVariable) -> str:
        return {"input": "continuous", "output": "discrete", "parameter": "fixed", "independent": "continuous"}[
            v.causality
        ]

    @staticmethod
    def initial(v: FmuVariable) -> str | None:
        return {"output": "calculated", "parameter": "exact"}.get(v.causality)

    @staticmethod
    def number(value: float | bool) -> str:
        return repr(float(value))

    def index(self, v: FmuVariable) -> int:
        """FMI 2 `index`: 1-based position in ModelVariables."""
        return self._indices[v.value_reference]

    @cached_property
    def _indices(self) -> dict[int, int]:
        """FMI 2 index of every value reference, built once (a lookup per variable would make rendering quadratic)."""
        return {x.value_reference: position for position, x in enumerate(self.variables, start=1)}

    @property
    def interpolates_inputs(self) -> bool:
        return self.component.interpolates_inputs

    def has_initial_dependencies(self, v: FmuVariable) -> bool:
        """False when output `v` depends on so many knowns at initialisation that the attribute is left out."""
        return self.initial_dependencies(v) is not None

    def has_step_dependencies(self, v: FmuVariable) -> bool:
        """False when output `v` depends on so many inputs at a communication point that the attribute is left out."""
        return self.step_dependencies(v) is not None

    def initial_dependencies(self, v: FmuVariable) -> str | None:
        """Knowns an output depends on at initialisation: FMI 2 indices or FMI 3 value references, ascending; None
        for more than MAX_LISTED_DEPENDENCIES (the attribute is left out: every known)."""
        return self._dependency_keys(self._source_key(v), initial=True)

    def step_dependencies(self, v: FmuVariable) -> str | None:
        """Inputs an output depends on at a communication point: none for a sampled FMU (its outputs change only in
        doStep), its graph sources for an interpolating one (inputs set there are the latest sample's); None for more
        than MAX_LISTED_DEPENDENCIES."""
        return self._dependency_keys(self._source_key(v), initial=False) if self.interpolates_inputs else ""

    def _source_key(self, v: FmuVariable) -> str | None:
        """What output `v`'s dependencies follow from: its graph tensor, or None for `extrapolating`."""
        if v.value_reference == self.fmu_variables.extrapolating.value_reference:
            return None
        return self.component.outputs[v.port_index].tensor

    def _dependency_keys(self, source: str | None, initial: bool) -> str | None:
        """The dependency list of every output with this source, computed once per source tensor."""
        cache = self._dependency_cache
        if (source, initial) not in cache:
            knowns = list(self._input_sources(source))
            if initial and source is not None:
                knowns.append(self.fmu_variables.output_gain)
            cache[(source, initial)] = self._keys(knowns) if len(knowns) <= MAX_LISTED_DEPENDENCIES else None
        return cache[(source, initial)]

    @cached_property
    def _dependency_cache(self) -> dict[tuple[str | None, bool], str | None]:
        return {}

    def _input_sources(self, source: str | None) -> list[FmuVariable]:
        """The inputs an output of graph tensor `source` is computed from (None, `extrapolating`: those with a
        training envelope)."""
        fv = self.fmu_variables
        if source is None:
            return [x for x in fv.inputs if self._has_envelope(x)]
        sources = self.dependencies.get(source, set())
        return [x for x in fv.inputs if self.component.inputs[x.port_index].tensor in sources]

    def _keys(self, knowns: list[FmuVariable]) -> str:
        """FMI 2 indices or FMI 3 value references of `knowns`, ascending, space-separated."""
        keys = sorted(self.index(x) if self.identity.fmi_version == 2 else x.value_reference for x in knowns)
        return " ".join(str(k) for k in keys)

    def _has_envelope(self, v: FmuVariable) -> bool:
        port = self.component.inputs[v.port_index]
        return port.min is not None or port.max is not None


_LIBRARY_TEXT = {"m": "the math library (-lm)", "dl": "the dl library (-ldl)"}


@functools.cache
def _environment() -> jinja2.Environment:
    """The XML templates' environment, made once per process (compiling the templates costs ~0.25 s per build)."""
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(templates_dir())),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def render_model_description(view: ModelDescriptionView) -> str:
    """modelDescription.xml for the FMI version of `view.identity`."""
    template = f"modelDescription{view.identity.fmi_version}.xml.j2"
    return _environment().get_template(template).render(md=view)


def render_build_description(
    identifier: str, source_files: list[str], libraries: Mapping[str | None, tuple[str, ...]] | None = None
) -> str:
    """sources/buildDescription.xml: how another platform compiles the FMU from its sources; `libraries` the libraries
    to link by FMI 3 platform, one build configuration each (None: one configuration for every platform, libm)."""
    by_platform = libraries if libraries is not None else {None: ("m",)}
    configurations = [
        {
            "platform": platform,
            "libraries": names,
            "description": "C99; link with " + " and ".join(_LIBRARY_TEXT.get(n, f"lib{n} (-l{n})") for n in names),
        }
        for platform, names in by_platform.items()
    ]
    template = _environment().get_template("buildDescription.xml.j2")
    return template.render(identifier=identifier, source_files=source_files, configurations=configurations)
