"""Add parameterised physical terms to an output of a step graph: output = network + sum of coefficient x basis.

A term is linear in its coefficient: a constant (a preload, a zero offset) or a coefficient times one input channel
(a spring rate times the displacement, an extra stiffness times a rotation). This is how the vehicle loop perturbs a
component's candidate effect in the co-simulation (one coefficient at a time, for the sensitivity of the vehicle's
channels) and how it fixes a component where no in-situ data exist (the coefficients fitted to the vehicle
residual). A channel the graph does not read yet becomes a new input port (unit given, no training envelope); the
reference stimulus gets it at zero. Needs only onnx and `nnfmu.component` (no torch).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from nnfmu.component import Component, Port
from nnfmu.export.errors import ExportError
from nnfmu.reference_stimulus import ReferenceStimulus


@dataclass(frozen=True)
class OutputTerm:
    """`coefficient` x `channel` (None: x 1) added to the output port `output`; `unit` is the channel's SI unit."""

    output: str
    channel: str | None
    coefficient: float
    unit: str = ""

    def __post_init__(self) -> None:
        if not math.isfinite(self.coefficient):
            raise ExportError(f"term on {self.output!r}: coefficient {self.coefficient!r} must be finite")


def add_output_terms(model: onnx.ModelProto, terms: Sequence[OutputTerm], description: str = "") -> onnx.ModelProto:
    """A copy of the nnfmu step graph `model` whose outputs carry `terms` (see module docstring); its `Component`
    updated (new input ports, the terms in its metadata). ExportError for a graph without nnfmu metadata, an output
    it does not have, or a channel whose tensor is not a scalar port."""
    if not any(p.key == "nnfmu.component" for p in model.metadata_props):
        raise ExportError(f"graph {model.graph.name!r} carries no nnfmu component description")
    component = Component.from_onnx(model)
    outputs = {p.name: p for p in component.outputs}
    inputs = {p.name: p for p in component.inputs}
    out = onnx.ModelProto()
    out.CopyFrom(model)
    graph = out.graph
    tensors = {vi.name for vi in (*graph.input, *graph.output)} | {n for node in graph.node for n in node.output}
    new_ports: list[Port] = []
    for term in terms:
        if term.output not in outputs:
            raise ExportError(f"graph {graph.name!r} has no output {term.output!r} (has: {', '.join(outputs)})")
        if term.channel is not None and term.channel not in inputs:
            if term.channel in tensors:
                raise ExportError(f"graph {graph.name!r}: {term.channel!r} is a tensor but not an input port")
            port = Port(term.channel, term.unit, f"{term.channel}, read by an added physical term")
            inputs[term.channel] = port
            new_ports.append(port)
            graph.input.append(helper.make_tensor_value_info(term.channel, TensorProto.DOUBLE, [1]))
    for name in dict.fromkeys(t.output for t in terms):
        port = outputs[name]
        if port.index != 0 or port.tensor != name:
            raise ExportError(f"graph {graph.name!r}: output {name!r} is not a tensor of its own")
        _add_terms(graph, name, [t for t in terms if t.output == name], inputs)
    updated = Component(
        name=component.name,
        inputs=[*component.inputs, *new_ports],
        outputs=component.outputs,
        states=component.states,
        sample_period=component.sample_period,
        description=description or component.description,
        metadata={
            **component.metadata,
            "added_terms": [
                {"output": t.output, "channel": t.channel, "coefficient": t.coefficient, "unit": t.unit} for t in terms
            ],
        },
        filter_cutoff=component.filter_cutoff,
        interval_starts=component.interval_starts,
    )
    updated.attach_to(out)
    stimulus = ReferenceStimulus.from_onnx(model)
    if stimulus is not None and new_ports:
        zeros = tuple(0.0 for _ in range(stimulus.length))
        ReferenceStimulus(stimulus.source, {**stimulus.inputs, **{p.name: zeros for p in new_ports}}).attach_to(out)
    onnx.checker.check_model(out, full_check=True)
    return out


def _add_terms(graph: onnx.GraphProto, output: str, terms: list[OutputTerm], inputs: dict[str, Port]) -> None:
    """Rename the producer of `output` to `<output>_network` and add output = that + each term."""
    network = f"{output}_network"
    for node in graph.node:
        node.output[:] = [network if n == output else n for n in node.output]
        node.input[:] = [network if n == output else n for n in node.input]
    total = network
    for i, term in enumerate(terms):
        coefficient = f"{output}_term{i}_coefficient"
        graph.initializer.append(numpy_helper.from_array(np.array([term.coefficient], dtype=np.float64), coefficient))
        value = coefficient
        if term.channel is not None:
            port = inputs[term.channel]
            value = f"{output}_term{i}"
            source = port.tensor
            if port.index != 0 or _size(graph, port.tensor) != 1:
                source = f"{output}_term{i}_{term.channel}"
                index = f"{source}_index"
                graph.initializer.append(numpy_helper.from_array(np.array([port.index], dtype=np.int64), index))
                graph.node.append(helper.make_node("Gather", [port.tensor, index], [source], name=source, axis=0))
            graph.node.append(helper.make_node("Mul", [coefficient, source], [value], name=value))
        summed = output if i == len(terms) - 1 else f"{output}_sum{i}"
        graph.node.append(helper.make_node("Add", [total, value], [summed], name=summed))
        total = summed


def _size(graph: onnx.GraphProto, tensor: str) -> int:
    """Static element count of graph input `tensor` (symbolic dimensions count as 1)."""
    for vi in graph.input:
        if vi.name == tensor:
            return int(np.prod([d.dim_value if d.dim_value > 0 else 1 for d in vi.type.tensor_type.shape.dim]))
    return 1
