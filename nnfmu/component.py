"""The component description: one object that feeds the ONNX metadata, the FMU model description, the C and the
Python FMU.

An nnfmu ONNX file is a *step function*: it maps the inputs at sample k (physical units) and the state at sample k
to the outputs at sample k (physical units) and the state at sample k+1. `Component` says which graph tensors are
ports, their units and training envelope, which tensor pairs are states, and the sample period the graph was trained
at. It is stored as JSON under the ONNX metadata key `nnfmu.component`; a graph without that key (another tool's ONNX)
gets a generic description read off its inputs and outputs.

This module needs only `onnx` (no torch), because building and running FMUs must not import torch.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import onnx

METADATA_KEY = "nnfmu.component"
FORMAT_VERSION = 1
# Sample periods a component may have [s]: shorter ones would make an FMU evaluate billions of samples per second.
SAMPLE_PERIOD_RANGE = (1e-9, 1e4)
PERIOD_TOLERANCE = 1e-6  # relative: a record's fitted period vs a model's (8-digit stamps resolve ~1e-8 of it)


def same_period(a: float, b: float) -> bool:
    """Whether two sample periods [s] name the same clock (within PERIOD_TOLERANCE, relative): the one test every
    comparison of a record's period with a model's, or of two models', uses."""
    return abs(a - b) <= PERIOD_TOLERANCE * max(abs(a), abs(b))


# Most ports (tensor elements) one graph from another tool may have: each becomes an FMU variable, so a declared
# input of a billion elements is refused before any port is made.
MAX_PORTS = 100_000
DEFAULT_FILTER_CUTOFF_HZ = 0.0  # off: an FMU computes its model; the thesis's 100 Hz is an option (docs/fmu.md)


@dataclass(frozen=True)
class Port:
    """One scalar input or output of the component, carried by one element of one graph tensor."""

    name: str
    unit: str = ""
    description: str = ""
    tensor: str = ""
    index: int = 0
    min: float | None = None
    max: float | None = None

    def __post_init__(self) -> None:
        if not self.tensor:
            object.__setattr__(self, "tensor", self.name)

    def in_envelope(self, value: float) -> bool:
        """True when `value` lies inside the training envelope (or no envelope is known)."""
        lo = -math.inf if self.min is None else self.min
        hi = math.inf if self.max is None else self.max
        return lo <= value <= hi


@dataclass(frozen=True)
class StatePort:
    """A graph input/output tensor pair that carries the model's state from sample k to sample k+1."""

    input: str
    output: str
    initial: tuple[float, ...]
    description: str = ""

    @property
    def size(self) -> int:
        return len(self.initial)


def replace_metadata(model: onnx.ModelProto, key: str, value: str) -> None:
    """Set the ONNX model's metadata entry `key` to `value`, dropping any earlier entry of that key."""
    kept = [p for p in model.metadata_props if p.key != key]
    del model.metadata_props[:]
    model.metadata_props.extend(kept)
    model.metadata_props.add(key=key, value=value)


@dataclass
class Component:
    """Everything a consumer of a step graph needs besides the graph itself.

    `sample_period` [s] is the period the model was trained at; `None` marks a stateless graph from another tool,
    which an FMU evaluates once per communication step. `interval_starts` maps each input tensor to the graph input
    that takes its value at the start of a sample's interval: such a component (a vehicle, solved exactly between
    samples) has its inputs interpolated linearly between samples by the FMU (docs/fmu.md); empty: inputs are
    sampled (a network). `filter_cutoff` [Hz] is the start value of the FMU's output
    low-pass (0: off, the default: what the FMU reports is the model itself). `metadata` holds provenance: nnfmu
    version, training data hash, feature spec, training settings and metrics.
    """

    name: str
    inputs: list[Port]
    outputs: list[Port]
    states: list[StatePort] = field(default_factory=list)
    sample_period: float | None = None
    description: str = ""
    metadata: dict[str, Any] = field(default_factory=dict)
    filter_cutoff: float = DEFAULT_FILTER_CUTOFF_HZ
    interval_starts: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.filter_cutoff) and self.filter_cutoff >= 0.0):
            raise ValueError(
                f"component {self.name!r}: filter_cutoff {self.filter_cutoff!r} Hz must be a finite number >= 0"
            )
        period = self.sample_period
        if period is not None:
            low, high = SAMPLE_PERIOD_RANGE
            if isinstance(period, bool) or not isinstance(period, (int, float)) or not low <= period <= high:
                raise ValueError(
                    f"component {self.name!r}: sample period {period!r} s must be a number from {low:g} to {high:g} s"
                )
            self.sample_period = float(period)
        if self.interval_starts:
            tensors = {p.tensor for p in self.inputs}
            if set(self.interval_starts) != tensors:
                raise ValueError(
                    f"component {self.name!r}: interval_starts names {sorted(self.interval_starts)}, "
                    f"but the input tensors are {sorted(tensors)}; name each input tensor once"
                )
            if self.sample_period is None:
                raise ValueError(f"component {self.name!r}: interpolated inputs need a sample period")

    @property
    def interpolates_inputs(self) -> bool:
        """True when the FMU interpolates the inputs linearly between samples (see `interval_starts`)."""
        return bool(self.interval_starts)

    @property
    def state_size(self) -> int:
        return sum(s.size for s in self.states)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["format_version"] = FORMAT_VERSION
        return d

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True, allow_nan=False)

    @classmethod
    def from_dict(cls, d: Any) -> "Component":
        """The component of a decoded description; ValueError naming the field when one has the wrong type (the
        description may come from any ONNX file)."""
        d = _mapping(d, "the description")
        version = _typed(d, "format_version", int, "the description", FORMAT_VERSION)
        if version > FORMAT_VERSION:
            raise ValueError(f"component description format {version} is newer than this nnfmu ({FORMAT_VERSION})")
        name = _typed(d, "name", str, "the description")
        where = f"component {name!r}"
        return cls(
            name=name,
            inputs=[_port(p, f"{where}, input {i}") for i, p in enumerate(_typed(d, "inputs", list, where))],
            outputs=[_port(p, f"{where}, output {i}") for i, p in enumerate(_typed(d, "outputs", list, where))],
            states=[_state(s, f"{where}, state {i}") for i, s in enumerate(_typed(d, "states", list, where, []))],
            sample_period=d.get("sample_period"),  # checked with its range in __post_init__
            description=_typed(d, "description", str, where, ""),
            metadata=_typed(d, "metadata", dict, where, {}),
            filter_cutoff=float(_typed(d, "filter_cutoff", NUMBER, where, DEFAULT_FILTER_CUTOFF_HZ)),
            interval_starts=_string_map(_typed(d, "interval_starts", dict, where, {}), f"{where}, interval_starts"),
        )

    def attach_to(self, model: onnx.ModelProto) -> None:
        """Store this description in the ONNX model's metadata (replacing an earlier one)."""
        replace_metadata(model, METADATA_KEY, self.to_json())

    @classmethod
    def from_onnx(cls, model: onnx.ModelProto, name: str | None = None) -> "Component":
        """Read the description of an ONNX model: nnfmu's metadata if present, else a generic one from the graph."""
        for prop in model.metadata_props:
            if prop.key == METADATA_KEY:
                try:
                    decoded = json.loads(prop.value)
                except RecursionError:
                    raise ValueError(
                        f"metadata {METADATA_KEY!r} is nested too deeply to be a component description"
                    ) from None
                component = cls.from_dict(decoded)
                if name:
                    component.name = name
                return component
        return generic_component(model, name or model.graph.name or "model")


NUMBER = (int, float)
_MISSING = object()


def _typed(d: dict[str, Any], key: str, kind: type | tuple[type, ...], where: str, default: Any = _MISSING) -> Any:
    """`d[key]` when it is of `kind` (a bool is no number), `default` when absent (None allowed where it is the
    default); ValueError naming the field otherwise."""
    if key not in d or (d[key] is None and default is None):
        if default is _MISSING:
            raise ValueError(f"{where}: {key!r} is missing")
        return default
    value = d[key]
    if isinstance(value, bool) and kind is not bool or not isinstance(value, kind):
        names = " or ".join(k.__name__ for k in (kind if isinstance(kind, tuple) else (kind,)))
        raise ValueError(f"{where}: {key!r} is {type(value).__name__} {repr(value)[:60]}, expected {names}")
    return value


def _mapping(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ValueError(f"{where} is a JSON {type(value).__name__}, expected an object")
    return value


def _string_map(value: dict[str, Any], where: str) -> dict[str, str]:
    for key, item in value.items():
        if not isinstance(item, str):
            raise ValueError(f"{where}: {key!r} maps to {type(item).__name__} {repr(item)[:60]}, expected str")
    return dict(value)


def _port(value: Any, where: str) -> Port:
    """A Port from its JSON object, every field of its type."""
    d = _mapping(value, where)
    unknown = sorted(set(d) - {"name", "unit", "description", "tensor", "index", "min", "max"})
    if unknown:
        raise ValueError(f"{where}: unknown field(s) {', '.join(map(repr, unknown))}")
    port = Port(
        name=_typed(d, "name", str, where),
        unit=_typed(d, "unit", str, where, ""),
        description=_typed(d, "description", str, where, ""),
        tensor=_typed(d, "tensor", str, where, ""),
        index=_typed(d, "index", int, where, 0),
        min=_typed(d, "min", NUMBER, where, None),
        max=_typed(d, "max", NUMBER, where, None),
    )
    if port.index < 0:
        raise ValueError(f"{where}: index {port.index} is negative")
    return port


def _state(value: Any, where: str) -> StatePort:
    """A StatePort from its JSON object, every field of its type."""
    d = _mapping(value, where)
    initial = _typed(d, "initial", list, where)
    for x in initial:
        if isinstance(x, bool) or not isinstance(x, NUMBER):
            raise ValueError(f"{where}: initial value {repr(x)[:60]} is not a number")
    return StatePort(
        _typed(d, "input", str, where),
        _typed(d, "output", str, where),
        tuple(initial),
        _typed(d, "description", str, where, ""),
    )


def _static_size(value_info: onnx.ValueInfoProto) -> int:
    """Number of elements of a tensor; symbolic or unknown dimensions (batch) count as 1."""
    size = 1
    for dim in value_info.type.tensor_type.shape.dim:
        size *= dim.dim_value if dim.HasField("dim_value") and dim.dim_value > 0 else 1
    return size


def _ports_of(value_infos: list[onnx.ValueInfoProto]) -> list[Port]:
    """One port per tensor element; ValueError naming the tensor, its size and MAX_PORTS before any is made when
    the tensors together have more elements than that."""
    sizes = [_static_size(vi) for vi in value_infos]
    for vi, size in zip(value_infos, sizes):
        if size > MAX_PORTS:
            raise ValueError(f"tensor {vi.name!r} has {size} elements, more than the {MAX_PORTS} ports an FMU may have")
    if sum(sizes) > MAX_PORTS:
        raise ValueError(
            f"tensors {', '.join(repr(vi.name) for vi in value_infos)} have {sum(sizes)} elements "
            f"together, more than the {MAX_PORTS} ports an FMU may have"
        )
    ports: list[Port] = []
    for vi, size in zip(value_infos, sizes):
        if size == 1:
            ports.append(Port(name=vi.name, tensor=vi.name, index=0))
        else:
            ports.extend(Port(name=f"{vi.name}[{i}]", tensor=vi.name, index=i) for i in range(size))
    return ports


def generic_component(model: onnx.ModelProto, name: str) -> Component:
    """Describe a graph from another tool: one port per tensor element, evaluated once per communication step."""
    initializers = {init.name for init in model.graph.initializer}
    graph_inputs = [vi for vi in model.graph.input if vi.name not in initializers]
    return Component(
        name=name,
        inputs=_ports_of(graph_inputs),
        outputs=_ports_of(list(model.graph.output)),
        description=model.doc_string or f"ONNX graph {model.graph.name!r}",
        metadata={"producer": f"{model.producer_name} {model.producer_version}".strip()},
    )
