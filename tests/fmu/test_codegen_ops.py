"""Per-operator checks of the C generator: tiny ONNX graphs compiled with gcc and compared with onnxruntime."""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import pytest
from onnx import TensorProto, helper, numpy_helper
from onnx.reference import ReferenceEvaluator

from nnfmu.fmu.native.codegen import GeneratedGraph, UnsupportedGraphError, generate_c

GCC = shutil.which("gcc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc not found on PATH: generated C cannot be compiled")
CFLAGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic"]
RTOL = {np.float64: 1e-9, np.float32: 1e-5}
ATOL = {np.float64: 1e-12, np.float32: 1e-6}
ONNX_TYPE = {np.float64: TensorProto.DOUBLE, np.float32: TensorProto.FLOAT}


def make_model(
    nodes: list[onnx.NodeProto],
    inputs: dict[str, np.ndarray],
    outputs: list[str],
    constants: dict[str, np.ndarray] | None = None,
    opset: int = 17,
    dims: dict[str, list[int | str]] | None = None,
    output_types: dict[str, type] | None = None,
) -> onnx.ModelProto:
    """A model whose graph inputs take their dtype/shape from example arrays (or `dims` for symbolic ones).

    Outputs have the first input's dtype unless `output_types` says otherwise; their shapes are left open.
    """
    dims = dims or {}
    default = next(iter(inputs.values())).dtype.type if inputs else np.float64
    output_types = output_types or {}
    graph_inputs = [
        helper.make_tensor_value_info(name, ONNX_TYPE[value.dtype.type], dims.get(name, list(value.shape)))
        for name, value in inputs.items()
    ]
    graph_outputs = [
        helper.make_tensor_value_info(name, ONNX_TYPE[output_types.get(name, default)], None) for name in outputs
    ]
    initializers = [numpy_helper.from_array(np.asarray(v), n) for n, v in (constants or {}).items()]
    graph = helper.make_graph(nodes, "test_graph", graph_inputs, graph_outputs, initializers)
    # ir_version 8: the installed onnxruntime may not read the newest IR version onnx writes by default.
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)], ir_version=8)


def reference(model: onnx.ModelProto, inputs: dict[str, np.ndarray]) -> list[np.ndarray]:
    """Outputs from onnxruntime."""
    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    return [np.asarray(r) for r in session.run(None, inputs)]


def compile_library(generated: GeneratedGraph, folder: Path, prefix: str = "nn") -> ctypes.CDLL:
    """Write graph.h/graph.c into `folder`, build a shared library with the strict flags and load it."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "graph.h").write_text(generated.header)
    (folder / "graph.c").write_text(generated.source)
    library = folder / f"lib{prefix}.so"
    command = [GCC, *CFLAGS, "-shared", "-fPIC", str(folder / "graph.c"), "-o", str(library), "-lm"]
    result = subprocess.run(command, capture_output=True, text=True)
    assert result.returncode == 0, f"gcc failed:\n{result.stderr}\n--- graph.c ---\n{generated.source}"
    return ctypes.CDLL(str(library))


def run_native(model: onnx.ModelProto, inputs: dict[str, np.ndarray], folder: Path, prefix: str = "nn"):
    """Generate, compile and run once; outputs flattened in graph order, split per output."""
    generated = generate_c(model, prefix)
    library = compile_library(generated, folder, prefix)
    run = getattr(library, f"{prefix}_graph_run")
    run.restype = ctypes.c_int
    flat_in = np.concatenate([np.ravel(v).astype(np.float64) for v in inputs.values()] or [np.zeros(0)])
    assert list(generated.input_sizes) == [v.size for v in inputs.values()]
    flat_out = np.zeros(sum(generated.output_sizes))
    pointer = ctypes.POINTER(ctypes.c_double)
    status = run(flat_in.ctypes.data_as(pointer), flat_out.ctypes.data_as(pointer))
    assert status == 0
    return np.split(flat_out, np.cumsum(generated.output_sizes)[:-1])


def assert_matches(
    model: onnx.ModelProto, inputs: dict[str, np.ndarray], folder: Path, expected=None, computed_in=None
) -> None:
    """Native C output equals onnxruntime (or `expected`) within the tolerance of the dtype it is computed in."""
    expected = reference(model, inputs) if expected is None else expected
    native = run_native(model, inputs, folder)
    assert len(native) == len(expected)
    for got, want in zip(native, expected):
        kind = computed_in or (want.dtype.type if want.dtype.type in RTOL else np.float64)
        assert got.size == want.size
        np.testing.assert_allclose(got, np.ravel(want).astype(np.float64), rtol=RTOL[kind], atol=ATOL[kind])


def rand(rng: np.random.Generator, *shape: int, dtype=np.float64) -> np.ndarray:
    return rng.normal(size=shape).astype(dtype)


UNARY_OPS = ["Neg", "Abs", "Exp", "Log", "Sqrt", "Tanh", "Sigmoid", "Relu", "LeakyRelu", "Softplus"]


@pytest.mark.slow
@needs_gcc
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("op", UNARY_OPS)
def test_unary(op: str, dtype, tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    x = rand(rng, 2, 3, dtype=dtype) * 3
    if op in ("Log", "Sqrt"):
        x = np.abs(x) + dtype(0.1)
    attrs = {"alpha": 0.2} if op == "LeakyRelu" else {}
    model = make_model([helper.make_node(op, ["x"], ["y"], name=f"{op}_node", **attrs)], {"x": x}, ["y"])
    expected = None
    if op == "Softplus" and dtype == np.float64:  # onnxruntime has no float64 Softplus kernel
        expected = [np.logaddexp(0.0, x)]
    assert_matches(model, {"x": x}, tmp_path, expected)


BROADCAST_SHAPES = [((2, 3), (2, 3)), ((2, 3), (3,)), ((2, 1), (1, 3)), ((4, 1, 3), (2, 1)), ((1,), (2, 3)), ((), (3,))]


@needs_gcc
@pytest.mark.parametrize("shapes", BROADCAST_SHAPES, ids=str)
@pytest.mark.parametrize("op", ["Add", "Sub", "Mul", "Div"])
def test_binary_broadcasting(op: str, shapes, tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    a, b = rand(rng, *shapes[0]), rand(rng, *shapes[1]) + 3.0
    model = make_model([helper.make_node(op, ["a", "b"], ["y"])], {"a": a, "b": b}, ["y"])
    assert_matches(model, {"a": a, "b": b}, tmp_path)


@needs_gcc
def test_binary_with_constant_operand_float32(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    a = rand(rng, 3, 2, dtype=np.float32)
    model = make_model(
        [helper.make_node("Div", ["w", "a"], ["y"])], {"a": a}, ["y"], {"w": rand(rng, 2, dtype=np.float32)}
    )
    assert_matches(model, {"a": a}, tmp_path)


GEMM_CASES = [
    dict(),
    dict(transA=1),
    dict(transB=1),
    dict(transA=1, transB=1, alpha=0.5, beta=-2.0),
    dict(alpha=1.5, bias=(1,)),
    dict(bias=(3, 4)),
    dict(bias=(3, 1)),
    dict(bias=None),
    dict(beta=0.0),
]


@needs_gcc
@pytest.mark.parametrize("case", GEMM_CASES, ids=str)
def test_gemm(case: dict, tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    case = dict(case)
    bias_shape = case.pop("bias", (4,))
    a = rand(rng, *((2, 3) if case.get("transA") else (3, 2)))
    b = rand(rng, *((4, 2) if case.get("transB") else (2, 4)))
    inputs, constants = {"a": a}, {"b": b}
    names = ["a", "b"]
    if bias_shape is not None:
        inputs["c"] = rand(rng, *bias_shape)
        names.append("c")
    model = make_model([helper.make_node("Gemm", names, ["y"], **case)], inputs, ["y"], constants)
    assert_matches(model, inputs, tmp_path)


def in_order(a: np.ndarray, b: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """A @ B + bias with each output summed from 0.0 over the inner index in order, one rounding per operation."""
    y = np.zeros((a.shape[0], b.shape[1]))
    for r in range(a.shape[0]):
        for c in range(b.shape[1]):
            acc = 0.0
            for j in range(a.shape[1]):
                acc += float(a[r, j]) * float(b[j, c])
            y[r, c] = acc + float(bias[c])
    return y


GEMM_FORMS = {  # how B reaches the Gemm, and what the generated C must show for it
    "sparse constant": r"acc\[\d+\] = 0\.0 \+ x0\[",  # only the nonzero products, each output's one expression
    "dense constant": "b_by_rows",  # transB: copied row by row for the side-by-side sums
    "dense constant with zero rows": r"for \(int j = 4; j < 7; \+\+j\)",  # rows 2, 3 and 7 left out of the loop
    "run-time input": r"acc\[c\] \+= a_j \* x1\[",
}


@needs_gcc
@pytest.mark.parametrize("trans_b", [0, 1])
@pytest.mark.parametrize("form", GEMM_FORMS)
def test_gemm_sums_each_output_in_order(form: str, trans_b: int, tmp_path: Path) -> None:
    """Whatever the form of B, each output is the in-order sum of its products bit for bit (the plain loop's
    result): the side-by-side sums and the written-out nonzero products only change how fast it is computed."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(2, 9)) * 10.0 ** rng.integers(-6, 6, size=(2, 9))
    b = rng.normal(size=(9, 5)) * 10.0 ** rng.integers(-6, 6, size=(9, 5))
    if form == "sparse constant":
        b[rng.random(b.shape) < 0.7] = 0.0
    if form == "dense constant with zero rows":
        b[[2, 3, 7]] = 0.0
    bias = rng.normal(size=5)
    stored = b.T.copy() if trans_b else b
    inputs = {"a": a, "bias": bias} | ({"b": stored} if form == "run-time input" else {})
    constants = {} if form == "run-time input" else {"b": stored}
    model = make_model([helper.make_node("Gemm", ["a", "b", "bias"], ["y"], transB=trans_b)], inputs, ["y"], constants)
    if form != "dense constant" or trans_b:
        assert re.search(GEMM_FORMS[form], generate_c(model, "nn").source)
    (y,) = run_native(model, inputs, tmp_path)
    assert np.array_equal(y, np.ravel(in_order(a, b, bias)))


MATMUL_SHAPES = [
    ((2, 3), (3, 4)),
    ((3,), (3, 4)),
    ((2, 3), (3,)),
    ((3,), (3,)),
    ((2, 2, 3), (3, 4)),
    ((2, 1, 2, 3), (3, 3, 2)),
]


@needs_gcc
@pytest.mark.parametrize("shapes", MATMUL_SHAPES, ids=str)
def test_matmul(shapes, tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    a, b = rand(rng, *shapes[0]), rand(rng, *shapes[1])
    model = make_model([helper.make_node("MatMul", ["a", "b"], ["y"])], {"a": a, "b": b}, ["y"])
    assert_matches(model, {"a": a, "b": b}, tmp_path)


@needs_gcc
@pytest.mark.parametrize("bounds", [("lo", "hi"), ("lo", ""), ("", "hi"), ("lo_in", "hi")])
def test_clip_with_inputs(bounds, tmp_path: Path) -> None:
    rng = np.random.default_rng(6)
    x = rand(rng, 4, 3) * 2
    inputs = {"x": x}
    if "lo_in" in bounds:
        inputs["lo_in"] = np.array(-0.3)
    model = make_model(
        [helper.make_node("Clip", ["x", *bounds], ["y"])], inputs, ["y"], {"lo": np.array(-0.5), "hi": np.array(0.7)}
    )
    assert_matches(model, inputs, tmp_path)


@needs_gcc
def test_clip_opset6_attributes_float32(tmp_path: Path) -> None:
    x = np.linspace(-2, 2, 9).astype(np.float32)
    model = make_model([helper.make_node("Clip", ["x"], ["y"], min=-1.0, max=0.5)], {"x": x}, ["y"], opset=6)
    assert_matches(model, {"x": x}, tmp_path)


@needs_gcc
def test_cast_between_float_and_double(tmp_path: Path) -> None:
    x = np.array([1.0 / 3.0, 1e-30, -2.5e10])
    nodes = [
        helper.make_node("Cast", ["x"], ["f"], to=TensorProto.FLOAT),
        helper.make_node("Tanh", ["f"], ["tf"]),
        helper.make_node("Cast", ["tf"], ["y"], to=TensorProto.DOUBLE),
    ]
    model = make_model(nodes, {"x": x}, ["y", "f"], output_types={"f": np.float32})
    generated = generate_c(model)
    assert "tanhf(" in generated.source  # the float part computes in float
    assert_matches(model, {"x": x}, tmp_path, computed_in=np.float32)


@needs_gcc
@pytest.mark.parametrize("axis", [0, 1, -1])
def test_concat(axis: int, tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    shape = [2, 3]
    shapes = []
    for extra in (1, 2, 3):
        s = list(shape)
        s[axis] = extra
        shapes.append(s)
    inputs = {"a": rand(rng, *shapes[0]), "b": rand(rng, *shapes[1])}
    model = make_model(
        [helper.make_node("Concat", ["a", "k", "b"], ["y"], axis=axis)], inputs, ["y"], {"k": rand(rng, *shapes[2])}
    )
    assert_matches(model, inputs, tmp_path)


SLICES = [
    dict(starts=[1], ends=[3], axes=[1], steps=None),
    dict(starts=[-1], ends=[-4], axes=[1], steps=[-1]),
    dict(starts=[-2, 4], ends=[-1, 0], axes=[0, -1], steps=[1, -2]),
    dict(starts=[0, 1], ends=[2**63 - 1, 2**63 - 1], axes=None, steps=[2, 1]),
    dict(starts=[2], ends=[-(2**63)], axes=[2], steps=[-1]),
]


@needs_gcc
@pytest.mark.parametrize("case", SLICES, ids=str)
def test_slice(case: dict, tmp_path: Path) -> None:
    rng = np.random.default_rng(8)
    x = rand(rng, 3, 5, 4)
    constants = {"starts": np.array(case["starts"]), "ends": np.array(case["ends"])}
    names = ["x", "starts", "ends"]
    for key in ("axes", "steps"):
        if case[key] is not None:
            constants[key] = np.array(case[key])
            names.append(key)
        elif key == "axes" and case["steps"] is not None:
            names.append("")
    model = make_model([helper.make_node("Slice", names, ["y"])], {"x": x}, ["y"], constants)
    assert_matches(model, {"x": x}, tmp_path)


@needs_gcc
def test_slice_opset9_attributes(tmp_path: Path) -> None:
    x = np.arange(12.0).reshape(3, 4)
    node = helper.make_node("Slice", ["x"], ["y"], starts=[1, -3], ends=[3, 100], axes=[0, 1])
    model = make_model([node], {"x": x}, ["y"], opset=9)
    assert_matches(model, {"x": x}, tmp_path)


GATHERS = [(0, np.array([2, 0, -1])), (1, np.array([[1, 0], [3, -4]])), (1, np.array(2)), (-1, np.array([0]))]


@needs_gcc
@pytest.mark.parametrize("axis, indices", GATHERS, ids=str)
def test_gather_constant_indices(axis: int, indices: np.ndarray, tmp_path: Path) -> None:
    rng = np.random.default_rng(9)
    x = rand(rng, 3, 4)
    model = make_model([helper.make_node("Gather", ["x", "i"], ["y"], axis=axis)], {"x": x}, ["y"], {"i": indices})
    assert_matches(model, {"x": x}, tmp_path)


SHAPING = [
    ("Reshape", {}, {"shape": np.array([0, -1, 2])}, 17),
    ("Flatten", {"axis": 0}, {}, 17),
    ("Flatten", {"axis": 2}, {}, 17),
    ("Flatten", {"axis": -1}, {}, 17),
    ("Squeeze", {}, {"axes": np.array([1])}, 17),
    ("Squeeze", {}, {}, 17),
    ("Squeeze", {"axes": [-2]}, {}, 11),
    ("Unsqueeze", {}, {"axes": np.array([0, -1])}, 17),
    ("Unsqueeze", {"axes": [2]}, {}, 11),
    ("Identity", {}, {}, 17),
    ("Transpose", {}, {}, 17),
    ("Transpose", {"perm": [1, 2, 0]}, {}, 17),
]


@needs_gcc
@pytest.mark.parametrize("op, attrs, constants, opset", SHAPING, ids=lambda v: str(v)[:30])
def test_shape_operators(op: str, attrs: dict, constants: dict, opset: int, tmp_path: Path) -> None:
    rng = np.random.default_rng(10)
    x = rand(rng, 2, 1, 4)
    node = helper.make_node(op, ["x", *constants], ["y"], **attrs)
    model = make_model([node], {"x": x}, ["y"], constants, opset=opset)
    expected = reference(model, {"x": x})
    assert_matches(model, {"x": x}, tmp_path, expected)
    assert tuple(expected[0].shape) == shape_of_output(model)


def shape_of_output(model: onnx.ModelProto) -> tuple[int, ...]:
    """The static shape the generator gave the first output (from the header's boundary comment)."""
    header = generate_c(model).header
    line = next(line for line in header.splitlines() if line.startswith("/* out[0.."))
    dims = line.split("[")[-1].split("]")[0]
    return tuple(int(d) for d in dims.split(", ") if d)


@needs_gcc
def test_constant_node_and_shape_derived_reshape(tmp_path: Path) -> None:
    """Shape -> Gather -> Concat -> Reshape folds at generation time; a Constant node feeds an Add."""
    rng = np.random.default_rng(11)
    x = rand(rng, 2, 6)
    nodes = [
        helper.make_node("Shape", ["x"], ["s"]),
        helper.make_node("Gather", ["s", "zero"], ["batch"], axis=0),
        helper.make_node("Concat", ["batch", "tail"], ["target"], axis=0),
        helper.make_node("Reshape", ["x", "target"], ["r"]),
        helper.make_node("Constant", [], ["c"], value=numpy_helper.from_array(rand(rng, 3, 2), "c")),
        helper.make_node("Add", ["r", "c"], ["y"]),
    ]
    constants = {"zero": np.array([0]), "tail": np.array([3, 2])}
    model = make_model(nodes, {"x": x}, ["y"], constants)
    assert_matches(model, {"x": x}, tmp_path)


def gru_model(
    seq: int, batch: int, width: int, hidden: int, linear_before_reset: int, dtype, with_bias: bool = True
) -> tuple[onnx.ModelProto, dict[str, np.ndarray]]:
    """A one-node GRU graph with a random initial hidden state; values are float32-representable in any dtype."""
    rng = np.random.default_rng(12 + seq + 10 * linear_before_reset)

    def values(*shape: int, scale: float) -> np.ndarray:
        return (rng.normal(size=shape) * scale).astype(np.float32).astype(dtype)

    constants = {"W": values(1, 3 * hidden, width, scale=0.7), "R": values(1, 3 * hidden, hidden, scale=0.7)}
    names = ["x", "W", "R"]
    if with_bias:
        constants["B"] = values(1, 6 * hidden, scale=0.5)
    names += ["B" if with_bias else "", "", "h0"]
    inputs = {"x": values(seq, batch, width, scale=1.0), "h0": values(1, batch, hidden, scale=1.0)}
    node = helper.make_node(
        "GRU", names, ["Y", "Y_h"], hidden_size=hidden, linear_before_reset=linear_before_reset, name="gru"
    )
    return make_model([node], inputs, ["Y", "Y_h"], constants), inputs


GRU_SIZES = [(1, 1), (3, 2)]


@needs_gcc
@pytest.mark.parametrize("linear_before_reset", [1, 0])
@pytest.mark.parametrize("seq, batch", GRU_SIZES, ids=str)
def test_gru_float32_against_onnxruntime(seq: int, batch: int, linear_before_reset: int, tmp_path: Path) -> None:
    model, inputs = gru_model(seq, batch, 3, 4, linear_before_reset, np.float32)
    assert_matches(model, inputs, tmp_path)


@needs_gcc
@pytest.mark.parametrize("linear_before_reset", [1, 0])
@pytest.mark.parametrize("seq, batch", GRU_SIZES, ids=str)
def test_gru_float64(seq: int, batch: int, linear_before_reset: int, tmp_path: Path) -> None:
    """onnxruntime has no float64 GRU kernel: float64 is checked against the ONNX reference implementation
    to 1e-9, and against onnxruntime run on the same (float32-representable) values in float32."""
    model, inputs = gru_model(seq, batch, 3, 4, linear_before_reset, np.float64)
    exact = ReferenceEvaluator(model).run(None, inputs)
    assert_matches(model, inputs, tmp_path / "exact", expected=exact)
    model32, inputs32 = gru_model(seq, batch, 3, 4, linear_before_reset, np.float32)
    rounded = reference(model32, inputs32)
    assert_matches(model, inputs, tmp_path / "ort", expected=rounded, computed_in=np.float32)


@needs_gcc
def test_gru_without_bias(tmp_path: Path) -> None:
    model, inputs = gru_model(2, 1, 2, 3, 1, np.float32, with_bias=False)
    assert_matches(model, inputs, tmp_path)


@needs_gcc
def test_gru_sequence_lens_must_equal_the_sequence_length(tmp_path: Path) -> None:
    model, inputs = gru_model(2, 1, 2, 3, 1, np.float32)
    node = model.graph.node[0]
    node.input[4] = "lens"
    model.graph.initializer.append(numpy_helper.from_array(np.array([2], dtype=np.int32), "lens"))
    assert_matches(model, inputs, tmp_path)
    model.graph.initializer[-1].CopyFrom(numpy_helper.from_array(np.array([1], dtype=np.int32), "lens"))
    with pytest.raises(UnsupportedGraphError, match=r"sequence_lens \[1\]"):
        generate_c(model)


def test_gru_reverse_direction_is_refused() -> None:
    model, _ = gru_model(1, 1, 2, 3, 1, np.float64)
    model.graph.node[0].attribute.append(helper.make_attribute("direction", "reverse"))
    with pytest.raises(UnsupportedGraphError, match=r"node 'gru' \(op GRU\).*direction"):
        generate_c(model)


@pytest.mark.parametrize("op", ["Conv", "LSTM"])
def test_unsupported_operator_names_op_node_and_fallback(op: str) -> None:
    rng = np.random.default_rng(13)
    if op == "Conv":
        x = rand(rng, 1, 1, 5)
        node = helper.make_node("Conv", ["x", "w"], ["y"], name="my conv")
        constants = {"w": rand(rng, 1, 1, 3)}
    else:
        x = rand(rng, 1, 1, 2)
        node = helper.make_node("LSTM", ["x", "w", "r"], ["y"], hidden_size=3, name="my conv")
        constants = {"w": rand(rng, 1, 12, 2), "r": rand(rng, 1, 12, 3)}
    model = make_model([node], {"x": x}, ["y"], constants)
    with pytest.raises(UnsupportedGraphError) as info:
        generate_c(model)
    message = str(info.value)
    assert op in message and "'my conv'" in message and "--backend pythonfmu" in message
    assert info.value.op_type == op and info.value.node_name == "my conv"


def test_integer_graph_input_is_refused() -> None:
    graph = helper.make_graph(
        [helper.make_node("Gather", ["x", "i"], ["y"], name="pick")],
        "g",
        [
            helper.make_tensor_value_info("x", TensorProto.DOUBLE, [3]),
            helper.make_tensor_value_info("i", TensorProto.INT64, [1]),
        ],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, None)],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    with pytest.raises(UnsupportedGraphError, match=r"graph input 'i'.*--backend pythonfmu"):
        generate_c(model)


def test_input_of_unknown_rank_is_refused() -> None:
    graph = helper.make_graph(
        [helper.make_node("Tanh", ["x"], ["y"])],
        "g",
        [helper.make_tensor_value_info("x", TensorProto.DOUBLE, None)],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, None)],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    with pytest.raises(UnsupportedGraphError, match=r"graph input 'x' has no shape"):
        generate_c(model)


def test_gemm_with_3d_operand_is_refused() -> None:
    x = np.zeros((1, 2, 3))
    node = helper.make_node("Gemm", ["x", "w"], ["y"], name="g3")
    model = make_model([node], {"x": x}, ["y"], {"w": np.zeros((3, 2))})
    with pytest.raises(UnsupportedGraphError, match=r"node 'g3' \(op Gemm\): input 0 must be 2-D"):
        generate_c(model)
