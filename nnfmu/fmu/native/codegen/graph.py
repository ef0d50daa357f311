"""Static analysis of an ONNX model: dtypes, static shapes, topological order, constant folding and pruning."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import onnx
from onnx import numpy_helper

from nnfmu.fmu.native.codegen import folding
from nnfmu.fmu.native.codegen.emitters.base import Emitter, Node
from nnfmu.fmu.native.codegen.errors import UnsupportedGraphError
from nnfmu.fmu.native.codegen.registry import emitter_for
from nnfmu.fmu.native.codegen.tensors import ONNX_TO_NUMPY, RUNTIME_DTYPES, Tensor, constant


@dataclass(frozen=True)
class Step:
    """One node computed at run time, with its emitter and the input positions passed to its C function."""

    node: Node
    emitter: Emitter
    data_inputs: tuple[int, ...]


@dataclass(frozen=True)
class StaticGraph:
    """A model reduced to what the C needs: run-time inputs, outputs and the steps between them, in order."""

    name: str
    inputs: list[Tensor]
    outputs: list[Tensor]
    steps: list[Step]


def analyse(model: onnx.ModelProto) -> StaticGraph:
    """Resolve every tensor's dtype and static shape, fold constants and keep the nodes the outputs need."""
    if model.functions:
        model = onnx.inliner.inline_local_functions(model)
    opset = _default_opset(model)
    graph = model.graph
    _check_single_assignment(graph)
    tensors: dict[str, Tensor] = {}
    for initializer in graph.initializer:
        tensors[initializer.name] = constant(initializer.name, numpy_helper.to_array(initializer))
    inputs = [_graph_input(value) for value in graph.input if value.name not in tensors]
    tensors.update({tensor.name: tensor for tensor in inputs})
    steps: list[Step] = []
    for proto in _topological(graph, set(tensors)):
        step = _resolve(proto, opset, tensors)
        if step is not None:
            steps.append(step)
    outputs = []
    for value in graph.output:
        if value.name not in tensors:
            raise UnsupportedGraphError(f"graph output {value.name!r} is not produced by any node")
        outputs.append(tensors[value.name])
    _check_against_onnx(model, tensors)
    return StaticGraph(graph.name, inputs, outputs, _needed(steps, outputs))


def _default_opset(model: onnx.ModelProto) -> int:
    """The default operator set's version, one the installed onnx knows (a newer one's operators may mean anything)."""
    for entry in model.opset_import:
        if entry.domain in ("", "ai.onnx"):
            newest = onnx.defs.onnx_opset_version()
            if not 1 <= entry.version <= newest:
                raise UnsupportedGraphError(
                    f"the model imports ONNX operator set {entry.version}; the installed onnx knows sets 1 to {newest}"
                )
            return entry.version
    raise UnsupportedGraphError("the model imports no version of the default ONNX operator set")


def _check_single_assignment(graph: onnx.GraphProto) -> None:
    """Each tensor is written once (ONNX graphs are in SSA form): by a graph input, an initializer or one node."""
    writer = {value.name: "a graph input" for value in graph.input}
    writer |= {initializer.name: "an initializer" for initializer in graph.initializer}
    for node in graph.node:
        for name in node.output:
            if not name:
                continue
            if name in writer:
                raise UnsupportedGraphError(
                    f"tensor {name!r} is written twice (first by {writer[name]}); an ONNX "
                    "graph assigns each tensor once",
                    op_type=node.op_type,
                    node_name=node.name,
                )
            writer[name] = f"node {node.name or '(unnamed)'!r} (op {node.op_type})"


def _graph_input(value: onnx.ValueInfoProto) -> Tensor:
    """A run-time graph input; symbolic or unknown dimensions (batch) are resolved to 1."""
    tensor_type = value.type.tensor_type
    dtype = ONNX_TO_NUMPY.get(tensor_type.elem_type)
    if dtype not in RUNTIME_DTYPES:
        raise UnsupportedGraphError(
            f"graph input {value.name!r} has ONNX element type {tensor_type.elem_type}; only float and double inputs"
        )
    if not tensor_type.HasField("shape"):
        raise UnsupportedGraphError(f"graph input {value.name!r} has no shape (unknown rank)")
    shape = tuple(d.dim_value if d.HasField("dim_value") and d.dim_value > 0 else 1 for d in tensor_type.shape.dim)
    return Tensor(value.name, dtype, shape)


def _topological(graph: onnx.GraphProto, available: set[str]) -> list[onnx.NodeProto]:
    """Nodes ordered so every input is produced before use: Kahn's algorithm in waves (a node's wave is one past its
    latest producer's), each wave in file order; linear in the graph, so long chains are fine."""
    consumers: dict[str, list[int]] = {}
    waiting: list[int] = []  # per node: how many of its input tensors are not produced yet
    for i, node in enumerate(graph.node):
        missing = {name for name in node.input if name and name not in available}
        waiting.append(len(missing))
        for name in missing:
            consumers.setdefault(name, []).append(i)
    wave = [0] * len(graph.node)
    ready = [i for i, count in enumerate(waiting) if count == 0]
    placed: list[int] = []
    while ready:
        i = ready.pop()
        placed.append(i)
        for name in {name for name in graph.node[i].output if name}:
            for consumer in consumers.get(name, ()):
                wave[consumer] = max(wave[consumer], wave[i] + 1)
                waiting[consumer] -= 1
                if waiting[consumer] == 0:
                    ready.append(consumer)
    if len(placed) < len(graph.node):
        known = set(available) | {name for i in placed for name in graph.node[i].output if name}
        first = graph.node[min(set(range(len(graph.node))) - set(placed))]
        missing_names = sorted(name for name in first.input if name and name not in known)
        raise UnsupportedGraphError(
            f"inputs {missing_names} are never produced (or the graph has a cycle)",
            op_type=first.op_type,
            node_name=first.name,
        )
    return [graph.node[i] for i in sorted(placed, key=lambda i: (wave[i], i))]


def _resolve(proto: onnx.NodeProto, opset: int, tensors: dict[str, Tensor]) -> Step | None:
    """Add the outputs of one node to `tensors`; a Step when it must run in C, None when folded."""
    node = Node(proto, opset, [tensors[name] if name else None for name in proto.input])
    folded, fold_error = _try_fold(node)
    if folded is not None:
        tensors.update({tensor.name: tensor for tensor in folded})
        return None
    try:
        emitter = emitter_for(node)
    except UnsupportedGraphError as err:
        if fold_error is not None:
            raise node.fail(f"constant folding failed ({fold_error}) and the operator is not supported") from err
        raise
    skipped = emitter.skipped_inputs(node)
    data = tuple(
        i for i, t in enumerate(node.inputs) if t is not None and i not in emitter.static_inputs and i not in skipped
    )
    types = emitter.infer(node)
    for index in data:
        if node.inputs[index].dtype not in RUNTIME_DTYPES:
            raise node.fail(f"input {index} has dtype {node.inputs[index].dtype}; C computes float and double only")
    outputs: list[Tensor | None] = []
    for name, (dtype, shape) in zip(proto.output, types):
        tensor = Tensor(name, np.dtype(dtype), tuple(int(d) for d in shape)) if name else None
        if tensor is not None and tensor.size == 0:
            raise node.fail(f"output {name!r} would be empty (shape {tensor.shape})")
        if tensor is not None:
            tensors[name] = tensor
        outputs.append(tensor)
    node.outputs = outputs
    return Step(node, emitter, data)


def _try_fold(node: Node) -> tuple[list[Tensor] | None, Exception | None]:
    """The node's outputs as constants when they are known now (Shape of a static shape, constant inputs);
    otherwise None and, if evaluation was tried and failed, the reason."""
    proto = node.proto
    present = [t for t in node.inputs if t is not None]
    if proto.op_type == "Shape" and len(present) == 1:
        return [constant(proto.output[0], folding.shape_of(proto, present[0].shape))], None
    if not folding.foldable(proto, [t.is_constant for t in present]):
        return None, None
    try:
        values = folding.fold(proto, {t.name: t.value for t in present}, node.opset)
    except Exception as err:  # the reference evaluator raises many types; an emitter may still handle the node
        return None, err
    return [constant(name, value) for name, value in zip(proto.output, values) if name], None


def _needed(steps: list[Step], outputs: list[Tensor]) -> list[Step]:
    """Only the steps the graph outputs depend on, in order."""
    wanted = {tensor.name for tensor in outputs}
    kept: list[Step] = []
    for step in reversed(steps):
        if any(t is not None and t.name in wanted for t in step.node.outputs):
            kept.append(step)
            wanted.update(step.node.inputs[i].name for i in step.data_inputs)
    return kept[::-1]


def _check_against_onnx(model: onnx.ModelProto, tensors: dict[str, Tensor]) -> None:
    """Cross-check the static shapes with ONNX shape inference wherever it found concrete dimensions."""
    try:
        inferred = onnx.shape_inference.infer_shapes(model)
    except (onnx.shape_inference.InferenceError, onnx.checker.ValidationError) as err:
        raise UnsupportedGraphError(f"ONNX shape inference rejects the model: {err}") from err
    graph = inferred.graph
    for value in [*graph.value_info, *graph.output]:
        tensor = tensors.get(value.name)
        dims = value.type.tensor_type.shape.dim if value.type.tensor_type.HasField("shape") else None
        if tensor is None or dims is None or not all(d.HasField("dim_value") for d in dims):
            continue
        theirs = tuple(d.dim_value for d in dims)
        if theirs != tensor.shape:
            raise UnsupportedGraphError(
                f"tensor {value.name!r}: static shape {tensor.shape} disagrees with ONNX shape inference {theirs}"
            )
