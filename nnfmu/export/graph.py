"""A small ONNX graph builder with readable, unique names and nnfmu's fixed operator set.

The builder refuses any operator outside `ALLOWED_OPS`, each of which the native C backend translates (Constant by
folding it; tests/export/test_graph_ops.py); the backend takes more, for foreign graphs. Needs only onnx.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from nnfmu.export.errors import ExportError

OPSET = 17
# onnx 1.23 writes IR 11 by default; IR 8 is what opset 17 was released with and every onnxruntime >= 1.14 loads.
IR_VERSION = 8
ALLOWED_OPS = frozenset(
    {
        "Gemm",
        "MatMul",
        "Add",
        "Sub",
        "Mul",
        "Div",
        "Tanh",
        "Relu",
        "Sqrt",
        "Concat",
        "Slice",
        "Gather",
        "Reshape",
        "Identity",
        "Constant",
        "GRU",
    }
)


class GraphBuilder:
    """Collects nodes and float64/int64 initializers; every tensor gets a readable name unique in the graph.

    `reserved` names (the graph's input and output tensors) are never given to an internal tensor; only
    `output` writes them.
    """

    def __init__(self, reserved: Iterable[str] = ()) -> None:
        self.nodes: list[onnx.NodeProto] = []
        self.initializers: list[onnx.TensorProto] = []
        self._used: set[str] = set(reserved)

    def _unique(self, name: str) -> str:
        candidate, n = name, 1
        while candidate in self._used:
            n += 1
            candidate = f"{name}_{n}"
        self._used.add(candidate)
        return candidate

    def constant(self, name: str, value: np.ndarray) -> str:
        """Add an initializer (float arrays become float64, integer arrays int64); return its tensor name."""
        array = np.asarray(value)
        array = array.astype(np.int64) if np.issubdtype(array.dtype, np.integer) else array.astype(np.float64)
        unique = self._unique(name)
        self.initializers.append(numpy_helper.from_array(np.ascontiguousarray(array), unique))
        return unique

    def node(self, op_type: str, inputs: list[str], name: str, **attributes: Any) -> str:
        """Add a single-output node named like its output tensor; return that tensor's name."""
        return self.node_outputs(op_type, inputs, [name], **attributes)[0]

    def node_outputs(self, op_type: str, inputs: list[str], names: list[str], **attributes: Any) -> list[str]:
        """Add a node with several outputs (an empty name skips an optional output); return their tensor names."""
        if op_type not in ALLOWED_OPS:
            raise ExportError(
                f"operator {op_type!r} (node {names[0]!r}) is not in nnfmu's operator set {sorted(ALLOWED_OPS)}"
            )
        outputs = [self._unique(n) if n else "" for n in names]
        self.nodes.append(helper.make_node(op_type, inputs, outputs, name=outputs[0], **attributes))
        return outputs

    def output(self, source: str, name: str) -> str:
        """Expose `source` as the graph tensor `name` (a reserved port name) through an Identity node."""
        self.nodes.append(helper.make_node("Identity", [source], [name], name=f"output {name}"))
        return name

    def model(
        self, graph_name: str, doc: str, inputs: list[tuple[str, int]], outputs: list[tuple[str, int]]
    ) -> onnx.ModelProto:
        """Wrap the nodes in a model; inputs/outputs are (tensor name, length) pairs of float64 vectors."""
        graph = helper.make_graph(
            self.nodes,
            graph_name,
            [helper.make_tensor_value_info(n, TensorProto.DOUBLE, [size]) for n, size in inputs],
            [helper.make_tensor_value_info(n, TensorProto.DOUBLE, [size]) for n, size in outputs],
            self.initializers,
            doc_string=doc,
        )
        model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="nnfmu")
        model.ir_version = IR_VERSION
        return model
