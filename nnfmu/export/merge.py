"""Merge several nnfmu step graphs into one, so one FMU carries several networks (a bushing's four channels).

The merged graph takes the union of the parts' input ports (a port two parts share is one graph input), gives every
part's outputs (names must not clash), and carries one state vector `state` [n] that is the concatenation of the
parts' states in order: each part reads its slice (Slice, then Reshape to the part's own state shape) and the parts'
next states are concatenated into `state_next`. Every other tensor of part i is renamed `part{i}_<name>`, so the
parts cannot collide. The parts run side by side on the same sample clock, so their sample periods must agree.
The parts' reference stimuli (if every part has one) become the merged graph's (`merge_stimuli`).
Needs only onnx and `nnfmu.component` (no torch).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from nnfmu.component import Component, Port, StatePort, same_period
from nnfmu.export.band import TRAINING_BAND, carried_band
from nnfmu.export.errors import ExportError
from nnfmu.export.graph import IR_VERSION, OPSET
from nnfmu.reference_stimulus import ReferenceStimulus, merge_stimuli

STATE = "state"
STATE_NEXT = "state_next"


class MergeError(ExportError):
    """Step graphs that cannot run as one: different sample periods, clashing ports or units, foreign operators."""


def _component(model: onnx.ModelProto, index: int) -> Component:
    if not any(p.key == "nnfmu.component" for p in model.metadata_props):
        raise MergeError(f"graph {index} ({model.graph.name!r}) carries no nnfmu component description")
    return Component.from_onnx(model)


def _sample_period(components: Sequence[Component]) -> float | None:
    periods = [c.sample_period for c in components]
    first = periods[0]
    for component, period in zip(components, periods):
        same = (period is None and first is None) or (
            period is not None and first is not None and same_period(period, first)
        )
        if not same:
            listed = ", ".join(f"{c.name}: {p!r} s" for c, p in zip(components, periods))
            raise MergeError(f"sample periods differ ({listed}); merged networks must share one sample clock")
    return first


def _shared_cutoff(components: Sequence[Component]) -> float:
    cutoffs = {c.filter_cutoff for c in components}
    if len(cutoffs) > 1:
        listed = ", ".join(f"{c.name}: {c.filter_cutoff:g} Hz" for c in components)
        raise MergeError(f"output filter cut-offs differ ({listed}); an FMU has one filter_cutoff parameter")
    return cutoffs.pop()


def _envelope(a: float | None, b: float | None, pick) -> float | None:
    return b if a is None else a if b is None else pick(a, b)


def merge_inputs(components: Sequence[Component]) -> list[Port]:
    """The union of the parts' input ports in first-seen order; a shared port keeps the envelope all parts trust
    (the intersection), and must have one unit and one tensor element in every part."""
    merged: dict[str, Port] = {}
    for component in components:
        for port in component.inputs:
            seen = merged.get(port.name)
            if seen is None:
                merged[port.name] = port
                continue
            if (seen.unit, seen.tensor, seen.index) != (port.unit, port.tensor, port.index):
                raise MergeError(
                    f"input {port.name!r}: {component.name} has unit {port.unit!r}, tensor "
                    f"{port.tensor!r}[{port.index}] but an earlier part has {seen.unit!r}, "
                    f"{seen.tensor!r}[{seen.index}]"
                )
            lo, hi = _envelope(seen.min, port.min, max), _envelope(seen.max, port.max, min)
            if lo is not None and hi is not None and lo > hi:
                raise MergeError(f"input {port.name!r}: the parts' training envelopes do not overlap")
            merged[port.name] = Port(seen.name, seen.unit, seen.description, seen.tensor, seen.index, lo, hi)
    return list(merged.values())


def merge_bands(components: Sequence[Component]) -> dict[str, object] | None:
    """The training band every part trusts, as metadata: per input the lowest edge of the parts that take it (as the
    envelope is their intersection); None when a part carries no band or the parts' power shares differ (the merged
    graph then says nothing about its inputs' band)."""
    bands = [carried_band(c) for c in components]
    shares = {str(c.metadata.get(TRAINING_BAND, {}).get("power_share")) for c in components}
    if not all(bands) or len(shares) != 1:
        return None
    edges: dict[str, float] = {}
    for band in bands:
        for name, edge in band.items():
            edges[name] = min(edge, edges.get(name, edge))
    return {"power_share": components[0].metadata[TRAINING_BAND]["power_share"], "upper_edge_Hz": edges}


def _check_outputs(components: Sequence[Component], inputs: list[Port]) -> list[Port]:
    outputs: list[Port] = []
    owners: dict[str, str] = {p.tensor: "input" for p in inputs}
    for component in components:
        for tensor in sorted({p.tensor for p in component.outputs}):
            if tensor in owners or tensor in (STATE, STATE_NEXT):
                clash = owners.get(tensor, "the merged state")
                raise MergeError(f"output tensor {tensor!r} of {component.name} clashes with {clash}")
            owners[tensor] = f"an output of {component.name}"
        outputs.extend(component.outputs)
    return outputs


def _state_shape(model: onnx.ModelProto, tensor: str) -> list[int]:
    for vi in model.graph.input:
        if vi.name == tensor:
            return [
                d.dim_value if d.HasField("dim_value") and d.dim_value > 0 else 1 for d in vi.type.tensor_type.shape.dim
            ]
    raise MergeError(f"graph {model.graph.name!r}: state tensor {tensor!r} is not a graph input")


class _Renamer:
    """Renames part i's internal tensors to `part{i}_<name>`; port tensors keep their names."""

    def __init__(self, index: int, keep: set[str]) -> None:
        self.prefix = f"part{index}_"
        self.keep = keep

    def __call__(self, name: str) -> str:
        return name if not name or name in self.keep else self.prefix + name


def _copy_part(
    model: onnx.ModelProto, rename: _Renamer, nodes: list[onnx.NodeProto], initializers: list[onnx.TensorProto]
) -> None:
    for init in model.graph.initializer:
        copied = TensorProto()
        copied.CopyFrom(init)
        copied.name = rename(init.name)
        initializers.append(copied)
    for node in model.graph.node:
        if any(a.type in (onnx.AttributeProto.GRAPH, onnx.AttributeProto.GRAPHS) for a in node.attribute):
            raise MergeError(
                f"graph {model.graph.name!r}: node {node.name!r} ({node.op_type}) holds a sub-graph, "
                "which the merge does not rename"
            )
        copied = onnx.NodeProto()
        copied.CopyFrom(node)
        copied.name = rename(node.name or node.output[0])
        copied.input[:] = [rename(n) for n in node.input]
        copied.output[:] = [rename(n) for n in node.output]
        nodes.append(copied)


def _check_opsets(models: Sequence[onnx.ModelProto]) -> None:
    for model in models:
        domains = {o.domain: o.version for o in model.opset_import}
        if domains.get("", OPSET) != OPSET or set(domains) - {"", "ai.onnx"}:
            raise MergeError(
                f"graph {model.graph.name!r} imports opsets {domains}; merging needs the default "
                f"domain at version {OPSET}"
            )


def merge_step_graphs(models: Sequence[onnx.ModelProto], name: str, description: str = "") -> onnx.ModelProto:
    """One step graph computing every part of `models` in a sample; its `Component` attached (see module docstring).

    Raises MergeError for fewer than one part, differing sample periods or filter cut-offs, an output name used
    twice or shared with an input, a shared input with different units, or a part without nnfmu metadata.
    """
    if not models:
        raise MergeError("nothing to merge: no step graphs given")
    components = [_component(m, i) for i, m in enumerate(models)]
    _check_opsets(models)
    period = _sample_period(components)
    cutoff = _shared_cutoff(components)
    inputs = merge_inputs(components)
    outputs = _check_outputs(components, inputs)
    port_tensors = {p.tensor for p in inputs} | {p.tensor for p in outputs}
    nodes: list[onnx.NodeProto] = []
    initializers: list[onnx.TensorProto] = []
    state_parts: list[str] = []
    initial: list[float] = []
    layout: list[dict[str, object]] = []
    for i, (model, component) in enumerate(zip(models, components)):
        rename = _Renamer(i, port_tensors)
        flatten: list[onnx.NodeProto] = []
        for state in component.states:
            start, size = len(initial), state.size
            shape = _state_shape(model, state.input)
            bounds = [
                numpy_helper.from_array(np.array([v], dtype=np.int64), rename(f"merge_{state.input}_{tag}"))
                for tag, v in (("start", start), ("end", start + size), ("axis", 0))
            ]
            initializers.extend(bounds)
            sliced = rename(f"merge_{state.input}_slice")
            nodes.append(helper.make_node("Slice", [STATE, *(b.name for b in bounds)], [sliced], name=sliced))
            shape_init = numpy_helper.from_array(np.array(shape, dtype=np.int64), rename(f"merge_{state.input}_shape"))
            flat_init = numpy_helper.from_array(np.array([size], dtype=np.int64), rename(f"merge_{state.output}_flat"))
            initializers.extend([shape_init, flat_init])
            nodes.append(
                helper.make_node("Reshape", [sliced, shape_init.name], [rename(state.input)], name=rename(state.input))
            )
            flat = rename(f"merge_{state.output}_flat_value")
            flatten.append(helper.make_node("Reshape", [rename(state.output), flat_init.name], [flat], name=flat))
            state_parts.append(flat)
            initial.extend(state.initial)
            layout.append(
                {
                    "part": component.name,
                    "state": state.input,
                    "start": start,
                    "size": size,
                    "description": state.description,
                }
            )
        _copy_part(model, rename, nodes, initializers)
        nodes.extend(flatten)
    graph_inputs = [
        helper.make_tensor_value_info(t, TensorProto.DOUBLE, _port_shape(models, components, t, True))
        for t in dict.fromkeys(p.tensor for p in inputs)
    ]
    graph_outputs = [
        helper.make_tensor_value_info(t, TensorProto.DOUBLE, _port_shape(models, components, t, False))
        for t in dict.fromkeys(p.tensor for p in outputs)
    ]
    states: list[StatePort] = []
    if state_parts:
        nodes.append(helper.make_node("Concat", state_parts, [STATE_NEXT], name=STATE_NEXT, axis=0))
        graph_inputs.append(helper.make_tensor_value_info(STATE, TensorProto.DOUBLE, [len(initial)]))
        graph_outputs.append(helper.make_tensor_value_info(STATE_NEXT, TensorProto.DOUBLE, [len(initial)]))
        summary = "; ".join(f"{p['part']} [{p['start']}:{int(p['start']) + int(p['size'])}]" for p in layout)
        states.append(StatePort(STATE, STATE_NEXT, tuple(initial), f"states of the merged parts: {summary}"))
    doc = description or "merged step graph of " + ", ".join(c.name for c in components)
    graph = helper.make_graph(nodes, name, graph_inputs, graph_outputs, initializers, doc_string=doc)
    merged = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="nnfmu")
    merged.ir_version = IR_VERSION
    merged.doc_string = doc
    Component(
        name=name,
        inputs=inputs,
        outputs=outputs,
        states=states,
        sample_period=period,
        description=doc,
        filter_cutoff=cutoff,
        metadata={
            "merged_from": [{"name": c.name, "description": c.description, "metadata": c.metadata} for c in components],
            "state_layout": layout,
            **({TRAINING_BAND: band} if (band := merge_bands(components)) is not None else {}),
        },
    ).attach_to(merged)
    stimulus = merge_stimuli([_stimulus(m, i) for i, m in enumerate(models)])
    if stimulus is not None:
        stimulus.attach_to(merged)
    onnx.checker.check_model(merged, full_check=True)
    return merged


def _stimulus(model: onnx.ModelProto, index: int) -> ReferenceStimulus | None:
    try:
        return ReferenceStimulus.from_onnx(model)
    except ValueError as err:
        raise MergeError(f"graph {index} ({model.graph.name!r}): {err}") from err


def _port_shape(
    models: Sequence[onnx.ModelProto], components: Sequence[Component], tensor: str, is_input: bool
) -> list[int]:
    """Declared shape of port tensor `tensor` in the first part that has it (symbolic dimensions as 1)."""
    for model in models:
        infos = model.graph.input if is_input else model.graph.output
        for vi in infos:
            if vi.name == tensor:
                if vi.type.tensor_type.elem_type != TensorProto.DOUBLE:
                    raise MergeError(f"graph {model.graph.name!r}: port tensor {tensor!r} is not float64")
                return [
                    d.dim_value if d.HasField("dim_value") and d.dim_value > 0 else 1
                    for d in vi.type.tensor_type.shape.dim
                ]
    raise MergeError(
        f"port tensor {tensor!r} is not a graph {'input' if is_input else 'output'} of any part "
        f"({', '.join(c.name for c in components)})"
    )
