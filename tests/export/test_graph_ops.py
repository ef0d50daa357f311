"""The exporter's operator set against the native C backend's: every operator an nnfmu step graph may hold
translates to C, so a graph `export_onnx` or `merge_step_graphs` writes always builds with the default backend."""

from __future__ import annotations

import numpy as np
from onnx import TensorProto, helper, numpy_helper

from nnfmu.export.graph import ALLOWED_OPS, IR_VERSION, OPSET
from nnfmu.fmu.native.codegen import SUPPORTED_OPS, generate_c

# Allowed operators the C generator has no emitter for, because it evaluates them at generation time
# (nnfmu/fmu/native/codegen/folding.py): a Constant node has no inputs, so its value is always known.
FOLDED = frozenset({"Constant"})


def test_every_operator_the_exporter_may_emit_translates_to_c() -> None:
    """ALLOWED_OPS is what GraphBuilder accepts (tests/export/test_export.py and test_merge.py check that exported and
    merged graphs stay inside it); each must have a C emitter or be folded away.

    The backend supports more than the exporter emits (Sigmoid, Clip, Transpose, Cast, ...) on purpose: `nnfmu build`
    also takes foreign ONNX graphs, e.g. a network exported by torch.onnx, not only nnfmu's own step graphs.
    """
    missing = ALLOWED_OPS - set(SUPPORTED_OPS) - FOLDED
    assert not missing, f"the exporter may emit {sorted(missing)}, which the C generator cannot translate"
    assert FOLDED <= ALLOWED_OPS and not FOLDED & set(SUPPORTED_OPS), "FOLDED lists an operator it need not"


def test_a_folded_operator_becomes_a_constant_in_the_c_source() -> None:
    """The one allowed operator without an emitter, a Constant node feeding an Add, generates C holding its value."""
    value = np.array([0.125, -3.5])
    nodes = [
        helper.make_node("Constant", [], ["c"], value=numpy_helper.from_array(value, "c"), name="c"),
        helper.make_node("Add", ["x", "c"], ["y"], name="add"),
    ]
    graph = helper.make_graph(
        nodes,
        "folded",
        [helper.make_tensor_value_info("x", TensorProto.DOUBLE, [2])],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, [2])],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)])
    model.ir_version = IR_VERSION
    source = generate_c(model).source
    assert "0.125, -3.5," in source
    assert "node_Add_add(t_x, w_c, t_y);" in source
