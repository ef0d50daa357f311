"""The generated `config.h` of a native FMU: counts, value references, port-to-graph maps, envelope, initial state.

The graph's C function takes all graph inputs flattened and concatenated in graph-input order (and returns the
outputs the same way); `GraphLayout` gives each tensor's offset in those vectors, so every port and state value
becomes one index. Every graph input element must be fed by a port or a state.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import jinja2
import onnx

from nnfmu.component import Component
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.model_description import GENERATION_TOOL, FmuIdentity
from nnfmu.fmu.names import c_comment, c_string_literal
from nnfmu.fmu.variables import FmuVariables
from nnfmu.resources import templates_dir


@dataclass(frozen=True)
class GraphLayout:
    """Offsets and sizes of the graph's run-time input and output tensors in the flat C vectors."""

    inputs: dict[str, tuple[int, int]]  # tensor name -> (offset, size)
    outputs: dict[str, tuple[int, int]]

    @classmethod
    def of(cls, model: onnx.ModelProto, input_sizes: list[int], output_sizes: list[int]) -> "GraphLayout":
        """Lay out `model`'s non-initializer inputs and its outputs with the element counts the C generator used."""
        initializers = {init.name for init in model.graph.initializer}
        input_names = [vi.name for vi in model.graph.input if vi.name not in initializers]
        output_names = [vi.name for vi in model.graph.output]
        if len(input_names) != len(input_sizes) or len(output_names) != len(output_sizes):
            raise FmuBuildError(
                f"the C generator reports {len(input_sizes)} inputs and {len(output_sizes)} outputs, the graph has "
                f"{len(input_names)} and {len(output_names)}"
            )
        return cls(_offsets(input_names, input_sizes), _offsets(output_names, output_sizes))

    def element(self, side: str, tensor: str, index: int, what: str) -> int:
        """Flat index of element `index` of `tensor` on `side` ("input"/"output"); `what` names the port in errors."""
        table = self.inputs if side == "input" else self.outputs
        if tensor not in table:
            known = ", ".join(map(repr, table))
            raise FmuBuildError(f"{what}: the graph has no {side} tensor {tensor!r} (it has {known})")
        offset, size = table[tensor]
        if not 0 <= index < size:
            raise FmuBuildError(f"{what}: element {index} of {side} tensor {tensor!r} does not exist (size {size})")
        return offset + index


def _offsets(names: list[str], sizes: list[int]) -> dict[str, tuple[int, int]]:
    table, offset = {}, 0
    for name, size in zip(names, sizes):
        table[name] = (offset, size)
        offset += size
    return table


@dataclass(frozen=True)
class PortMap:
    """Where every port and state value sits in the graph's flat input/output vectors."""

    inputs: list[int]
    input_starts: list[int]  # where each input's value at the start of a sample interval goes (interpolating FMUs)
    outputs: list[int]
    state_inputs: list[int]
    state_outputs: list[int]
    state_initial: list[float]


def port_map(component: Component, layout: GraphLayout) -> PortMap:
    """Map ports and states to flat graph indices; fail if a graph input element would be left unfed."""
    inputs = [layout.element("input", p.tensor, p.index, f"input port {p.name!r}") for p in component.inputs]
    starts = (
        [
            layout.element("input", component.interval_starts[p.tensor], p.index, f"start of input port {p.name!r}")
            for p in component.inputs
        ]
        if component.interpolates_inputs
        else []
    )
    outputs = [layout.element("output", p.tensor, p.index, f"output port {p.name!r}") for p in component.outputs]
    state_in, state_out, initial = [], [], []
    for state in component.states:
        for j, value in enumerate(state.initial):
            state_in.append(layout.element("input", state.input, j, f"state {state.input!r}"))
            state_out.append(layout.element("output", state.output, j, f"state {state.input!r} -> {state.output!r}"))
            initial.append(float(value))
        for side, tensor in (("input", state.input), ("output", state.output)):
            size = (layout.inputs if side == "input" else layout.outputs)[tensor][1]
            if size != state.size:
                raise FmuBuildError(
                    f"state {state.input!r}: {len(state.initial)} initial values but {side} tensor "
                    f"{tensor!r} has {size} elements"
                )
    fed = set(inputs) | set(starts) | set(state_in)
    if len(fed) != len(inputs) + len(starts) + len(state_in):
        raise FmuBuildError("two ports or states feed the same graph input element")
    for tensor, (offset, size) in layout.inputs.items():
        missing = [i for i in range(size) if offset + i not in fed]
        if missing:
            raise FmuBuildError(f"graph input {tensor!r} element {missing[0]} is neither an input port nor a state")
    return PortMap(inputs, starts, outputs, state_in, state_out, initial)


def c_double(value: float) -> str:
    """A C double literal that reads back exactly; infinities become HUGE_VAL."""
    if math.isnan(value):
        raise FmuBuildError("NaN cannot appear in the FMU configuration")
    if math.isinf(value):
        return "HUGE_VAL" if value > 0 else "-HUGE_VAL"
    text = repr(float(value))
    return text if any(c in text for c in ".e") else f"{text}.0"


def _c_list(items: list[str], empty: str) -> str:
    return ", ".join(items) if items else empty


def render_config(
    component: Component, variables: FmuVariables, ports: PortMap, identity: FmuIdentity, source: str
) -> str:
    """config.h text for `component`; `source` (the ONNX file name) appears in a comment only."""
    inputs = [component.inputs[v.port_index] for v in variables.inputs]
    lows = [c_double(p.min if p.min is not None else -math.inf) for p in inputs]
    highs = [c_double(p.max if p.max is not None else math.inf) for p in inputs]
    period = component.sample_period
    if period is not None and not (math.isfinite(period) and period > 0):
        raise FmuBuildError(f"sample period {period!r} s is not a positive number")
    first_in = variables.inputs[0].value_reference if variables.inputs else 0
    first_out = variables.outputs[0].value_reference if variables.outputs else variables.extrapolating.value_reference
    values = {
        "comment_identifier": c_comment(identity.identifier),
        "comment_tool": c_comment(GENERATION_TOOL),
        "comment_source": c_comment(source),
        "identifier": c_string_literal(identity.identifier),
        "token": c_string_literal(identity.token),
        "n_inputs": len(variables.inputs),
        "n_outputs": len(variables.outputs),
        "n_state": len(ports.state_inputs),
        "has_sample_period": int(period is not None),
        "sample_period": c_double(period if period is not None else 0.0),
        "vr_first_input": first_in,
        "vr_first_output": first_out,
        "vr_extrapolating": variables.extrapolating.value_reference,
        "vr_filter_cutoff": variables.filter_cutoff.value_reference,
        "vr_output_gain": variables.output_gain.value_reference,
        "vr_time": variables.time.value_reference,
        "default_filter_cutoff": c_double(float(variables.filter_cutoff.start)),
        "default_output_gain": c_double(float(variables.output_gain.start)),
        "input_names": _c_list([c_string_literal(v.name) for v in variables.inputs], '""'),
        "input_units": _c_list([c_string_literal(v.unit) for v in variables.inputs], '""'),
        "input_graph_index": _c_list([str(i) for i in ports.inputs], "0"),
        "interpolates_inputs": int(component.interpolates_inputs),
        "has_time_variable": int(identity.fmi_version == 3),
        "input_start_graph_index": _c_list([str(i) for i in ports.input_starts] or ["0"] * len(ports.inputs), "0"),
        "input_min": _c_list(lows, "0.0"),
        "input_max": _c_list(highs, "0.0"),
        "output_names": _c_list([c_string_literal(v.name) for v in variables.outputs], '""'),
        "output_graph_index": _c_list([str(i) for i in ports.outputs], "0"),
        "state_graph_input": _c_list([str(i) for i in ports.state_inputs], "0"),
        "state_graph_output": _c_list([str(i) for i in ports.state_outputs], "0"),
        "state_initial": _c_list([c_double(x) for x in ports.state_initial], "0.0"),
    }
    _check_consecutive(variables)
    return _environment().get_template("config.h.j2").render(c=values)


@functools.cache
def _environment() -> jinja2.Environment:
    """The C header templates' environment, made once per process (its templates compiled once)."""
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(templates_dir())),
        autoescape=False,
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
    )


def _check_consecutive(variables: FmuVariables) -> None:
    """The C glue maps value references to ports by offset: inputs and outputs must be consecutive."""
    for group in (variables.inputs, variables.outputs):
        vrs = [v.value_reference for v in group]
        if vrs and vrs != list(range(vrs[0], vrs[0] + len(vrs))):
            raise FmuBuildError(f"value references {vrs} are not consecutive")
