"""Whole-graph checks of the C generator: hostile names, interface, linkage, re-entrancy, state loops, valgrind."""

from __future__ import annotations

import importlib.util
import io
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper
from onnx.reference import ReferenceEvaluator

from nnfmu.fmu.native.codegen import UnsupportedGraphError, generate_c

# The model builders and the compile-and-compare helpers live in the per-operator test module; load it by path so
# this works whatever pytest import mode or sys.path the suite runs with.
_spec = importlib.util.spec_from_file_location("codegen_op_helpers", Path(__file__).with_name("test_codegen_ops.py"))
_ops = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_ops)
CFLAGS, GCC, needs_gcc = _ops.CFLAGS, _ops.GCC, _ops.needs_gcc
assert_matches, make_model, rand, reference, run_native = (
    _ops.assert_matches,
    _ops.make_model,
    _ops.rand,
    _ops.reference,
    _ops.run_native,
)

HOSTILE = [
    "quo\"te's",
    "a<b>&c",
    "*/ evil /*",
    "line\nbreak\\",
    "ünïcødé 😀",
    "1st",
    "int",
    "return",
    "??/",
    "a-b",
    "a.b",
]


@needs_gcc
def test_hostile_names_compile_and_run(tmp_path: Path) -> None:
    """Tensor and node names with quotes, <, */, newlines, unicode, leading digits and C keywords."""
    rng = np.random.default_rng(20)
    x, v = rand(rng, 1, 2), rand(rng, 1, 2)
    inputs = {HOSTILE[0]: x, HOSTILE[1]: v}
    nodes = [
        helper.make_node("Add", [HOSTILE[0], HOSTILE[1]], [HOSTILE[2]], name=HOSTILE[3]),
        helper.make_node("Gemm", [HOSTILE[2], HOSTILE[5], HOSTILE[6]], [HOSTILE[7]], name=HOSTILE[4]),
        helper.make_node("Tanh", [HOSTILE[7]], [HOSTILE[9]], name=HOSTILE[8]),
        helper.make_node("Neg", [HOSTILE[9]], [HOSTILE[10]], name=HOSTILE[2]),
    ]
    constants = {HOSTILE[5]: rand(rng, 2, 3), HOSTILE[6]: rand(rng, 3)}
    model = make_model(nodes, inputs, [HOSTILE[10], HOSTILE[9]], constants)
    model.graph.name = "graph */ with\nnewline"
    model.producer_name = "evil */ producer"
    source = generate_c(model).source
    assert "evil */" not in source and "*/ evil" not in source
    assert all(ord(c) < 128 for c in source)
    assert_matches(model, inputs, tmp_path)


def test_prefix_must_be_a_c_identifier() -> None:
    model = make_model([helper.make_node("Tanh", ["x"], ["y"])], {"x": np.zeros(1)}, ["y"])
    with pytest.raises(ValueError, match="prefix"):
        generate_c(model, prefix="1 bad")


def mlp_gru_step_model(hidden: int = 4) -> tuple[onnx.ModelProto, list[str]]:
    """An nnfmu-like step graph: velocity, displacement and a GRU state in; force and the next state out."""
    rng = np.random.default_rng(21)
    constants = {
        "scale": np.array([0.5, 2.0]),
        "gru.W": rand(rng, 1, 3 * hidden, 2) * 0.6,
        "gru.R": rand(rng, 1, 3 * hidden, hidden) * 0.6,
        "gru.B": rand(rng, 1, 6 * hidden) * 0.3,
        "h_shape": np.array([1, 1, hidden]),
        "x_shape": np.array([1, 1, 2]),
        "fc1.W": rand(rng, 5, hidden),
        "fc1.b": rand(rng, 5),
        "fc2.W": rand(rng, 1, 5),
        "fc2.b": rand(rng, 1),
        "flat": np.array([-1]),
    }
    nodes = [
        helper.make_node("Concat", ["velocity", "displacement"], ["features"], axis=0, name="/features/Concat"),
        helper.make_node("Mul", ["features", "scale"], ["scaled"], name="/scale/Mul"),
        helper.make_node("Reshape", ["scaled", "x_shape"], ["x_seq"], name="/x/Reshape"),
        helper.make_node("Reshape", ["state", "h_shape"], ["h0"], name="/h0/Reshape"),
        helper.make_node(
            "GRU",
            ["x_seq", "gru.W", "gru.R", "gru.B", "", "h0"],
            ["", "h1"],
            hidden_size=hidden,
            linear_before_reset=1,
            name="/gru/GRU",
        ),
        helper.make_node("Reshape", ["h1", "flat"], ["state_next"], name="/state/Reshape"),
        helper.make_node("Unsqueeze", ["state_next", "zero"], ["h_row"], name="/h/Unsqueeze"),
        helper.make_node("Gemm", ["h_row", "fc1.W", "fc1.b"], ["z1"], transB=1, name="/fc1/Gemm"),
        helper.make_node("Tanh", ["z1"], ["a1"], name="/act/Tanh"),
        helper.make_node("Gemm", ["a1", "fc2.W", "fc2.b"], ["z2"], transB=1, name="/fc2/Gemm"),
        helper.make_node("Reshape", ["z2", "flat"], ["force"], name="/force/Reshape"),
    ]
    constants["zero"] = np.array([0])
    inputs = {"velocity": np.zeros(1), "displacement": np.zeros(1), "state": np.zeros(hidden)}
    return make_model(nodes, inputs, ["force", "state_next"], constants), list(inputs)


@pytest.mark.slow
@needs_gcc
def test_state_loop_matches_reference_over_steps(tmp_path: Path) -> None:
    """Feed state_next back as state for 20 samples; each sample equals the ONNX reference within 1e-9."""
    model, _ = mlp_gru_step_model()
    generated = generate_c(model)
    assert generated.input_sizes == [1, 1, 4] and generated.output_sizes == [1, 4]
    evaluator = ReferenceEvaluator(model)
    rng = np.random.default_rng(22)
    state = np.zeros(4)
    for step in range(20):
        inputs = {"velocity": rng.normal(size=1), "displacement": rng.normal(size=1), "state": state}
        expected = evaluator.run(None, inputs)
        assert_matches(model, inputs, tmp_path / f"step{step}", expected=expected)
        state = expected[1]
    assert np.abs(state).max() > 0.05  # the state actually evolved


@needs_gcc
def test_header_interface_and_only_one_external_symbol(tmp_path: Path) -> None:
    model, _ = mlp_gru_step_model()
    generated = generate_c(model, prefix="damper")
    assert "#define DAMPER_N_IN 6" in generated.header
    assert "#define DAMPER_N_OUT 5" in generated.header
    assert "int damper_graph_run(const double *in, double *out);" in generated.header
    (tmp_path / "graph.h").write_text(generated.header)
    (tmp_path / "graph.c").write_text(generated.source)
    subprocess.run([GCC, *CFLAGS, "-c", "graph.c", "-o", "graph.o"], cwd=tmp_path, check=True)
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("nm not found: cannot list the object's external symbols")
    listing = subprocess.run([nm, "-g", "--defined-only", "graph.o"], cwd=tmp_path, capture_output=True, text=True)
    assert [line.split()[-1] for line in listing.stdout.splitlines()] == ["damper_graph_run"]


def test_generated_code_is_reentrant_and_documented() -> None:
    """No writable static storage; weights are static const; each node has a function with an op/node comment."""
    model, _ = mlp_gru_step_model()
    source = generate_c(model).source
    assert not re.findall(r"^\s*static (?!const |void )", source, flags=re.MULTILINE)
    assert len(re.findall(r"^static const double w_", source, flags=re.MULTILINE)) == 8
    for node in model.graph.node:  # every node of this graph computes at run time
        assert f'/* ONNX {node.op_type} node "{node.name}"' in source
    assert "generated by nnfmu" in source and "malloc" not in source


@needs_gcc
def test_symbolic_batch_dimension_resolves_to_one(tmp_path: Path) -> None:
    rng = np.random.default_rng(23)
    x = rand(rng, 1, 3)
    nodes = [helper.make_node("MatMul", ["x", "w"], ["h"]), helper.make_node("Sigmoid", ["h"], ["y"])]
    model = make_model(nodes, {"x": x}, ["y"], {"w": rand(rng, 3, 2)}, dims={"x": ["N", 3]})
    generated = generate_c(model)
    assert generated.input_sizes == [3] and generated.output_sizes == [2]
    assert_matches(model, {"x": x}, tmp_path)


@needs_gcc
def test_constant_and_passthrough_outputs(tmp_path: Path) -> None:
    """An output folded to a constant (Shape of an input) and an output that is a graph input."""
    x = np.arange(6.0).reshape(2, 3)
    nodes = [helper.make_node("Shape", ["x"], ["s"]), helper.make_node("Cast", ["s"], ["shape"], to=TensorProto.DOUBLE)]
    model = make_model(nodes, {"x": x}, ["shape", "x"])
    native = run_native(model, {"x": x}, tmp_path)
    np.testing.assert_array_equal(native[0], [2.0, 3.0])
    np.testing.assert_array_equal(native[1], x.ravel())


@needs_gcc
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_weights_are_printed_exactly_with_inf_and_nan(dtype, tmp_path: Path) -> None:
    """x + w with x = 0 returns w bit for bit, including extremes, subnormals, infinities and NaN."""
    rng = np.random.default_rng(24)
    info = np.finfo(dtype)
    special = [info.max, info.tiny, info.tiny / 8, -np.inf, np.inf, np.nan, -0.0]
    weights = np.concatenate([rng.normal(size=20) * 10.0 ** rng.integers(-30, 30, size=20), special]).astype(dtype)
    x = np.zeros(weights.size, dtype=dtype)
    model = make_model([helper.make_node("Add", ["x", "w"], ["y"])], {"x": x}, ["y"], {"w": weights})
    native = run_native(model, {"x": x}, tmp_path)[0]
    np.testing.assert_array_equal(native, weights.astype(np.float64))
    np.testing.assert_array_equal(native, reference(model, {"x": x})[0].astype(np.float64))


def test_too_large_intermediate_tensors_are_refused() -> None:
    x = np.zeros(1)
    model = make_model([helper.make_node("Add", ["x", "w"], ["y"])], {"x": x}, ["y"], {"w": np.zeros(40000)})
    with pytest.raises(UnsupportedGraphError, match="stack.*--backend pythonfmu"):
        generate_c(model)


def test_unsupported_op_among_supported_ones_is_named() -> None:
    """Errors name the exact node even among supported ones, and the hint to the fallback backend."""
    x = np.zeros((1, 1, 4))
    nodes = [
        helper.make_node("Tanh", ["x"], ["t"], name="ok"),
        helper.make_node("MaxPool", ["t"], ["y"], kernel_shape=[2], name="pool/1"),
    ]
    model = make_model(nodes, {"x": x}, ["y"])
    with pytest.raises(UnsupportedGraphError, match=r"node 'pool/1' \(op MaxPool\).*--backend pythonfmu"):
        generate_c(model)


def _graph(nodes: list, opset: int = 17) -> onnx.ModelProto:
    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])
    return helper.make_model(helper.make_graph(nodes, "g", [x], [y]), opset_imports=[helper.make_opsetid("", opset)])


@pytest.mark.parametrize("opset", [99, 0])
def test_an_operator_set_onnx_does_not_know_is_refused(opset: int) -> None:
    """An operator set from the future (or none) gives its operators unknown meanings: refused, not guessed."""
    with pytest.raises(UnsupportedGraphError, match=rf"operator set {opset}; .* knows sets 1 to \d+"):
        generate_c(_graph([helper.make_node("Relu", ["x"], ["y"])], opset))


@pytest.mark.parametrize(
    ("nodes", "tensor"),
    [
        (
            [
                helper.make_node("Relu", ["x"], ["t"], name="a"),
                helper.make_node("Neg", ["x"], ["t"], name="b"),
                helper.make_node("Identity", ["t"], ["y"]),
            ],
            "t",
        ),
        ([helper.make_node("Relu", ["x"], ["x"], name="b"), helper.make_node("Identity", ["x"], ["y"])], "x"),
        ([helper.make_node("Relu", ["x"], ["y"], name="a"), helper.make_node("Neg", ["x"], ["y"], name="b")], "y"),
    ],
    ids=["intermediate", "graph input", "graph output"],
)
def test_a_tensor_written_twice_is_refused_before_the_compiler(nodes: list, tensor: str) -> None:
    with pytest.raises(UnsupportedGraphError, match=rf"node 'b' .*tensor '{tensor}' is written twice"):
        generate_c(_graph(nodes))


HARNESS = r"""
#include <stdio.h>
#include "graph.h"

int main(void)
{
    double in[NN_N_IN];
    double out[NN_N_OUT];
    for (int i = 0; i < NN_N_IN; ++i) {
        if (scanf("%lf", &in[i]) != 1) {
            return 2;
        }
    }
    if (nn_graph_run(in, out) != 0) {
        return 3;
    }
    for (int i = 0; i < NN_N_OUT; ++i) {
        printf("%.17g\n", out[i]);
    }
    return 0;
}
"""


@pytest.mark.slow
@needs_gcc
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind not found on PATH")
def test_mlp_gru_executable_runs_clean_under_valgrind(tmp_path: Path) -> None:
    model, names = mlp_gru_step_model()
    generated = generate_c(model)
    (tmp_path / "graph.h").write_text(generated.header)
    (tmp_path / "graph.c").write_text(generated.source)
    (tmp_path / "main.c").write_text(HARNESS)
    build = [GCC, *CFLAGS, "-g", "graph.c", "main.c", "-o", "harness", "-lm"]
    subprocess.run(build, cwd=tmp_path, check=True)
    inputs = {"velocity": np.array([0.3]), "displacement": np.array([-1.2]), "state": np.array([0.1, -0.2, 0.3, 0.05])}
    stdin = "\n".join(f"{v:.17g}" for name in names for v in inputs[name])
    command = ["valgrind", "--error-exitcode=1", "--leak-check=full", "--errors-for-leak-kinds=all", "./harness"]
    result = subprocess.run(command, cwd=tmp_path, input=stdin, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "ERROR SUMMARY: 0 errors" in result.stderr
    printed = np.array([float(line) for line in result.stdout.split()])
    expected = np.concatenate([np.ravel(r) for r in ReferenceEvaluator(model).run(None, inputs)])
    np.testing.assert_allclose(printed, expected, rtol=1e-9, atol=1e-12)


@needs_gcc
@pytest.mark.filterwarnings("ignore")  # the TorchScript exporter's deprecation and tracer warnings
def test_torch_exported_gru_step_matches_torch(tmp_path: Path) -> None:
    """A float64 torch GRU + linear step exported by torch.onnx (TorchScript exporter) runs natively to 1e-9."""
    torch = pytest.importorskip("torch")

    class Step(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.gru = torch.nn.GRU(2, 5, batch_first=True, dtype=torch.float64)
            self.out = torch.nn.Linear(5, 1, dtype=torch.float64)

        def forward(self, velocity, displacement, state):
            features = torch.cat([velocity, displacement]).reshape(1, 1, 2)
            y, h = self.gru(features, state.reshape(1, 1, 5))
            return self.out(y).reshape(1), h.reshape(5)

    torch.manual_seed(25)
    step = Step()
    args = tuple(torch.tensor(v, dtype=torch.float64) for v in ([0.4], [-0.7], [0.3, -0.2, 0.5, 0.1, -0.6]))
    buffer = io.BytesIO()
    names = ["velocity", "displacement", "state"]
    outputs = ["force", "state_next"]
    torch.onnx.export(step, args, buffer, dynamo=False, input_names=names, output_names=outputs, opset_version=17)
    model = onnx.load_from_string(buffer.getvalue())
    assert "GRU" in {node.op_type for node in model.graph.node}
    with torch.no_grad():
        expected = [t.numpy() for t in step(*args)]
    assert_matches(model, {n: a.numpy() for n, a in zip(names, args)}, tmp_path, expected=expected)
