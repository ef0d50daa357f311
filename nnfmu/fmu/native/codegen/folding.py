"""Constant folding at generation time: nodes whose inputs are all known become constant tensors."""

from __future__ import annotations

import numpy as np
import onnx
from onnx.reference import ReferenceEvaluator

# Operators whose result must not be frozen into the C code even when their inputs are constant.
NOT_FOLDABLE = frozenset(
    {"RandomNormal", "RandomUniform", "RandomNormalLike", "RandomUniformLike", "Multinomial", "Bernoulli"}
)


def foldable(node: onnx.NodeProto, known: list[bool]) -> bool:
    """Whether `node` can be evaluated now: all present inputs known, deterministic, no subgraphs."""
    if node.op_type in NOT_FOLDABLE or node.domain not in ("", "ai.onnx"):
        return False
    if any(a.type in (onnx.AttributeProto.GRAPH, onnx.AttributeProto.GRAPHS) for a in node.attribute):
        return False
    return all(known)


def fold(node: onnx.NodeProto, values: dict[str, np.ndarray], opset: int) -> list[np.ndarray]:
    """Evaluate one node with the ONNX reference implementation; one array per output."""
    evaluator = ReferenceEvaluator(node, opsets={"": opset})
    feeds = {name: values[name] for name in node.input if name}
    return [np.asarray(result) for result in evaluator.run(None, feeds)]


def shape_of(node: onnx.NodeProto, shape: tuple[int, ...]) -> np.ndarray:
    """The value of a Shape node (with optional start/end attributes) on a tensor of static `shape`."""
    start, end = 0, None
    for attribute in node.attribute:
        if attribute.name == "start":
            start = attribute.i
        elif attribute.name == "end":
            end = attribute.i
    return np.array(shape[start:end], dtype=np.int64)
