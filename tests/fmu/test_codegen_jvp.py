"""The generated forward-mode derivative `nn_graph_jvp` of every operator with a tangent rule: its outputs equal the run
function's bit for bit, its tangents equal central differences of the run function, and kinks take the documented
branch. Tiny graphs compiled with gcc (the per-operator models of test_codegen_ops.py)."""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper
from test_codegen_ops import compile_library, gru_model, make_model, needs_gcc, rand

from nnfmu.fmu.native.codegen import generate_c

POINTER = ctypes.POINTER(ctypes.c_double)
EPS = 1e-6


class CompiledGraph:
    """graph.c of a model compiled and loaded: `run(x)` and `jvp(x, dx)` on the flat input vector."""

    def __init__(self, model: onnx.ModelProto, folder: Path) -> None:
        self.generated = generate_c(model)
        assert self.generated.has_jvp, self.generated.jvp_missing
        library = compile_library(self.generated, folder)
        self._run, self._jvp = library.nn_graph_run, library.nn_graph_jvp
        self.n_out = sum(self.generated.output_sizes)

    def run(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.n_out)
        assert self._run(np.ascontiguousarray(x).ctypes.data_as(POINTER), out.ctypes.data_as(POINTER)) == 0
        return out

    def jvp(self, x: np.ndarray, dx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out, out_dot = np.zeros(self.n_out), np.zeros(self.n_out)
        x, dx = np.ascontiguousarray(x), np.ascontiguousarray(dx)
        pointers = (x.ctypes.data_as(POINTER), dx.ctypes.data_as(POINTER))
        assert self._jvp(*pointers, out.ctypes.data_as(POINTER), out_dot.ctypes.data_as(POINTER)) == 0
        return out, out_dot


def check_against_differences(model: onnx.ModelProto, inputs: dict[str, np.ndarray], folder: Path) -> np.ndarray:
    """jvp's outputs equal run's exactly and its tangents central differences of run (1e-6 relative) in 3 random
    directions; returns the last tangent."""
    graph = CompiledGraph(model, folder)
    x = np.concatenate([np.ravel(v).astype(np.float64) for v in inputs.values()])
    rng = np.random.default_rng(7)
    for _ in range(3):
        dx = rng.normal(size=x.size)
        out, out_dot = graph.jvp(x, dx)
        np.testing.assert_array_equal(out, graph.run(x))
        step = EPS * max(1.0, float(np.abs(x).max()))
        central = (graph.run(x + step * dx) - graph.run(x - step * dx)) / (2.0 * step)
        scale = max(1.0, float(np.abs(central).max()))
        np.testing.assert_allclose(out_dot, central, rtol=1e-6, atol=1e-6 * scale)
    return out_dot


UNARY_OPS = ["Neg", "Abs", "Exp", "Log", "Sqrt", "Tanh", "Sigmoid", "Relu", "LeakyRelu", "Softplus"]


@needs_gcc
@pytest.mark.parametrize("op", UNARY_OPS)
def test_unary_tangents(op: str, tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    x = rand(rng, 2, 3) * 3
    if op in ("Log", "Sqrt"):
        x = np.abs(x) + 0.1
    attrs = {"alpha": 0.2} if op == "LeakyRelu" else {}
    model = make_model([helper.make_node(op, ["x"], ["y"], **attrs)], {"x": x}, ["y"])
    check_against_differences(model, {"x": x}, tmp_path)


@needs_gcc
@pytest.mark.parametrize("op", ["Add", "Sub", "Mul", "Div"])
@pytest.mark.parametrize("constant", [None, "a", "b"])
def test_binary_tangents_with_broadcasting_and_constants(op: str, constant: str | None, tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    a, b = rand(rng, 2, 1), rand(rng, 1, 3) + 3.0
    inputs = {name: v for name, v in (("a", a), ("b", b)) if name != constant}
    constants = {name: v for name, v in (("a", a), ("b", b)) if name == constant}
    model = make_model([helper.make_node(op, ["a", "b"], ["y"])], inputs, ["y"], constants)
    check_against_differences(model, inputs, tmp_path)


@needs_gcc
@pytest.mark.parametrize("runtime", ["a", "b", "c", "ab", "abc"])
def test_gemm_tangents(runtime: str, tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    values = {"a": rand(rng, 3, 2), "b": rand(rng, 4, 3), "c": rand(rng, 4)}
    inputs = {k: v for k, v in values.items() if k in runtime}
    constants = {k: v for k, v in values.items() if k not in runtime}
    node = helper.make_node("Gemm", ["a", "b", "c"], ["y"], transA=1, transB=1, alpha=0.7, beta=1.3)
    model = make_model([node], inputs, ["y"], constants)
    check_against_differences(model, inputs, tmp_path)


@needs_gcc
@pytest.mark.parametrize("runtime", ["a", "b", "ab"])
def test_matmul_tangents_with_batches(runtime: str, tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    values = {"a": rand(rng, 2, 1, 3, 4), "b": rand(rng, 3, 4, 2)}
    inputs = {k: v for k, v in values.items() if k in runtime}
    constants = {k: v for k, v in values.items() if k not in runtime}
    model = make_model([helper.make_node("MatMul", ["a", "b"], ["y"])], inputs, ["y"], constants)
    check_against_differences(model, inputs, tmp_path)


@needs_gcc
def test_clip_tangent_follows_the_bound_it_returns(tmp_path: Path) -> None:
    """Clipped elements take the run-time bound's tangent, the others the input's."""
    x = np.array([-2.0, -0.5, 0.3, 0.9, 2.5])
    lo, hi = np.array(-1.0), np.array(1.0)
    model = make_model([helper.make_node("Clip", ["x", "lo", "hi"], ["y"])], {"x": x, "lo": lo, "hi": hi}, ["y"])
    graph = CompiledGraph(model, tmp_path)
    flat = np.concatenate([x, [-1.0, 1.0]])
    dx = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 10.0, 20.0])
    np.testing.assert_array_equal(graph.jvp(flat, dx)[1], [10.0, 2.0, 3.0, 4.0, 20.0])
    check_against_differences(model, {"x": x, "lo": lo, "hi": hi}, tmp_path / "fd")


@needs_gcc
def test_kinks_take_the_documented_branch(tmp_path: Path) -> None:
    """Relu and Abs have derivative 0 at 0; sqrt passes a zero tangent at 0 as 0 (not NaN)."""
    x = np.zeros(1)
    nodes = [
        helper.make_node("Relu", ["x"], ["r"]),
        helper.make_node("Abs", ["x"], ["a"]),
        helper.make_node("Mul", ["x", "zero"], ["z"]),
        helper.make_node("Sqrt", ["z"], ["s"]),
    ]
    model = make_model(nodes, {"x": x}, ["r", "a", "s"], {"zero": np.zeros(1)})
    graph = CompiledGraph(model, tmp_path)
    np.testing.assert_array_equal(graph.jvp(x, np.ones(1))[1], [0.0, 0.0, 0.0])


@needs_gcc
def test_data_movement_and_cast_tangents(tmp_path: Path) -> None:
    """Concat (with a constant part), Slice, Gather, Reshape, Transpose, Identity, Squeeze and casts through float32."""
    rng = np.random.default_rng(5)
    x = rand(rng, 2, 3)
    constants = {
        "k": rand(rng, 2, 2),
        "starts": np.array([1]),
        "ends": np.array([5]),
        "axes": np.array([1]),
        "idx": np.array([3, 0, 1]),
        "shape": np.array([-1]),
    }
    nodes = [
        helper.make_node("Tanh", ["x"], ["t"]),
        helper.make_node("Concat", ["t", "k", "x"], ["c"], axis=1),
        helper.make_node("Slice", ["c", "starts", "ends", "axes"], ["s"]),
        helper.make_node("Gather", ["s", "idx"], ["g"], axis=1),
        helper.make_node("Transpose", ["g"], ["tr"]),
        helper.make_node("Identity", ["tr"], ["i"]),
        helper.make_node("Reshape", ["i", "shape"], ["r"]),
        helper.make_node("Cast", ["r"], ["f"], to=TensorProto.FLOAT),
        helper.make_node("Cast", ["f"], ["d"], to=TensorProto.DOUBLE),
        helper.make_node("Mul", ["d", "r"], ["y"]),
    ]
    model = make_model(nodes, {"x": x}, ["y", "r"], constants)
    graph = CompiledGraph(model, tmp_path)
    flat = x.ravel()
    dx = rng.normal(size=flat.size)
    out, out_dot = graph.jvp(flat, dx)
    np.testing.assert_array_equal(out, graph.run(flat))
    step = 1e-3  # the float32 round trip limits the differences' accuracy; the r output below is exact
    central = (graph.run(flat + step * dx) - graph.run(flat - step * dx)) / (2.0 * step)
    np.testing.assert_allclose(out_dot, central, rtol=1e-4, atol=1e-4)
    check_against_differences(make_model(nodes[:7], {"x": x}, ["r"], constants), {"x": x}, tmp_path / "double")


def test_a_node_without_tangent_rule_leaves_out_the_derivative() -> None:
    """A GRU node has no tangent rule: the graph still runs, and says why it has no derivative."""
    model, _ = gru_model(1, 1, 2, 3, 1, np.float64)
    generated = generate_c(model)
    assert not generated.has_jvp and "GRU" in generated.jvp_missing
    assert "NN_HAS_JVP 0" in generated.header and "nn_graph_jvp(" not in generated.source
