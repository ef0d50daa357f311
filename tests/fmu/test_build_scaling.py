"""`nnfmu build` on other tools' graphs scales with the graph: time linear in ports, a stated port limit refused
before anything is allocated, and long node chains walked without recursion."""

from __future__ import annotations

import time
from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper

from nnfmu.component import MAX_PORTS
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.native import backend as native_build
from nnfmu.fmu.options import BuildOptions

OPSET = 17
IR_VERSION = 8


def _foreign_model(nodes: list[onnx.NodeProto], input_shape: list[int], output_shape: list[int]) -> onnx.ModelProto:
    """A graph as another tool writes it: no nnfmu metadata, a double input `x` and output `y`."""
    graph = helper.make_graph(
        nodes,
        "other_tool",
        [helper.make_tensor_value_info("x", TensorProto.DOUBLE, input_shape)],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, output_shape)],
    )
    return helper.make_model(
        graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="other-tool", ir_version=IR_VERSION
    )


def _vector_graph(n: int) -> onnx.ModelProto:
    """y = tanh(x) on a [1, n] vector: n input and n output ports, every output computed from the input tensor."""
    return _foreign_model([helper.make_node("Tanh", ["x"], ["y"], name="tanh")], [1, n], [1, n])


def _python_side_build_seconds(model: onnx.ModelProto, folder: Path, monkeypatch: pytest.MonkeyPatch) -> float:
    """Seconds `build_fmu` takes with the C compiler left out (its time is gcc's, not nnfmu's)."""
    monkeypatch.setattr(native_build, "compile_all", lambda *args, **kwargs: None)
    path = folder / "vector.onnx"
    onnx.save(model, str(path))
    start = time.perf_counter()
    build_fmu(path, BuildOptions(out=folder / "vector.fmu", platforms=("linux64",)))
    return time.perf_counter() - start


def test_build_time_grows_about_linearly_in_ports(tmp_path, monkeypatch):
    (tmp_path / "small").mkdir()
    (tmp_path / "large").mkdir()
    _python_side_build_seconds(_vector_graph(20), tmp_path / "small", monkeypatch)  # imports and templates, once
    small = min(_python_side_build_seconds(_vector_graph(200), tmp_path / "small", monkeypatch) for _ in range(2))
    # the best of two on each side: one run of the large graph alone caught a pause of the other xdist worker in CI
    # (0.075 s vs 1.268 s; 0.11 s vs 0.50 s on idle cores)
    large = min(_python_side_build_seconds(_vector_graph(2000), tmp_path / "large", monkeypatch) for _ in range(2))
    assert large < 15 * max(small, 0.02), f"200 ports: {small:.3f} s, 2000 ports: {large:.3f} s"


def test_a_huge_declared_input_is_refused_naming_tensor_size_and_limit(tmp_path, monkeypatch):
    path = tmp_path / "huge.onnx"
    onnx.save(
        _foreign_model([helper.make_node("Tanh", ["x"], ["y"], name="tanh")], [1_000_000_000], [1_000_000_000]),
        str(path),
    )
    out = tmp_path / "huge.fmu"
    start = time.perf_counter()
    with pytest.raises(FmuBuildError, match=rf"(?s)(?=.*'x')(?=.*1000000000)(?=.*{MAX_PORTS})"):
        build_fmu(path, BuildOptions(out=out))
    assert time.perf_counter() - start < 10.0  # refused up front, not after allocating ports
    assert not out.exists()


def test_one_port_over_the_limit_is_refused_and_the_limit_itself_is_not():
    from nnfmu.component import Component

    def model(n: int) -> onnx.ModelProto:
        return _foreign_model([helper.make_node("Identity", ["x"], ["y"])], [n], [1])

    with pytest.raises(ValueError, match=rf"'x'.*{MAX_PORTS + 1}.*{MAX_PORTS}"):
        Component.from_onnx(model(MAX_PORTS + 1))
    assert len(Component.from_onnx(model(MAX_PORTS)).inputs) == MAX_PORTS


def test_a_3000_node_chain_builds_without_recursion_error(tmp_path, monkeypatch):
    monkeypatch.setattr(native_build, "compile_all", lambda *args, **kwargs: None)  # the walks are Python
    n = 3000
    names = ["x", *[f"t{i}" for i in range(1, n)], "y"]
    nodes = [
        helper.make_node("Identity" if i % 2 else "Neg", [names[i]], [names[i + 1]], name=f"n{i}") for i in range(n)
    ]
    path = tmp_path / "chain.onnx"
    onnx.save(_foreign_model(nodes, [1], [1]), str(path))
    fmu = build_fmu(path, BuildOptions(out=tmp_path / "chain.fmu", platforms=("linux64",)))
    assert fmu.is_file()
