"""ONNX export: onnxruntime reproduces the torch model sample by sample; metadata, conventions and failures."""

from __future__ import annotations

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch

from nnfmu.component import Component
from nnfmu.export import ExportError, export_onnx, run_step_graph
from nnfmu.export.graph import ALLOWED_OPS, OPSET
from nnfmu.models.features import FeatureSpec, Lowpass, SmoothSign, Tap
from nnfmu.models.networks import MLP, GRUNet
from nnfmu.models.scaling import MinMaxScaler
from nnfmu.models.trained import TrainedModel

T = 0.002
UNITS = {"velocity": "m/s", "displacement": "m", "force": "N"}


def signals(channels: list[str], n: int, seed: int) -> dict[str, np.ndarray]:
    """Smooth random rig-like signals, a different amplitude per channel."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * T
    return {
        c: (0.3 + i) * (np.sin(2 * np.pi * rng.uniform(1, 5) * t + rng.uniform(0, 6)) + 0.3 * rng.normal(size=n))
        for i, c in enumerate(channels)
    }


def make_model(spec: FeatureSpec, recurrent: bool, units: dict[str, str] | None = None, seed: int = 0) -> TrainedModel:
    """A model with random weights (enlarged so the tanh units work in their nonlinear range) and fitted scalers."""
    torch.manual_seed(seed)
    network = GRUNet(spec.n_features, 6) if recurrent else MLP(spec.n_features, 7)
    with torch.no_grad():
        for p in network.parameters():
            p.mul_(3.0)
    train = signals(spec.channels, 500, seed + 1)
    target = np.random.default_rng(seed).normal(scale=800.0, size=500)
    return TrainedModel(
        spec=spec,
        network=network,
        feature_scaler=MinMaxScaler.fit(spec.features(train, T)),
        target_scaler=MinMaxScaler.fit(target),
        sample_period=T,
        units=units or UNITS,
        envelope={c: (float(train[c].min()), float(train[c].max())) for c in spec.channels},
        metrics={"test": {"nrmse": 0.05}},
        data_hash="ab" * 32,
        settings={"epochs": 3, "hidden": 7, "seed": np.int64(seed)},
        band={c: 20.0 + 5 * i for i, c in enumerate(spec.channels)},
    )


MLP_SPEC = FeatureSpec(
    taps=(Tap("velocity", (0, 1, 2)), Tap("displacement", (0, 3))),
    output="force",
    derived=(SmoothSign("velocity", scale=0.05), Lowpass("velocity", tau=0.01)),
)
GRU_SPEC = FeatureSpec(
    taps=(Tap("velocity", (0, 1)), Tap("displacement")), output="force", derived=(Lowpass("displacement", tau=0.02),)
)


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize("spec, recurrent", [(MLP_SPEC, False), (GRU_SPEC, True)], ids=["mlp", "gru"])
def test_step_graph_reproduces_torch_model(tmp_path, spec, recurrent):
    model = make_model(spec, recurrent)
    test = signals(spec.channels, 300, seed=7)
    result = export_onnx(model, tmp_path / "model.onnx", name="damper", verify_on=test)
    assert result.max_relative_error <= 1e-9 and result.verified_samples == 300
    reference = model.predict(test)
    assert np.ptp(reference) > 100.0  # the check compares a lively output, not a constant
    assert relative(run_step_graph(result.path, test)["force"], reference) <= 1e-9


@pytest.mark.parametrize("spec, recurrent", [(MLP_SPEC, False), (GRU_SPEC, True)], ids=["mlp", "gru"])
def test_graph_follows_the_step_convention(tmp_path, spec, recurrent):
    model = make_model(spec, recurrent)
    path = export_onnx(model, tmp_path / "m.onnx").path
    graph = onnx.load(path)
    onnx.checker.check_model(graph, full_check=True)
    n_state = spec.state_size + (6 if recurrent else 0)

    def shapes(vis):
        return [
            (v.name, v.type.tensor_type.elem_type, [d.dim_value for d in v.type.tensor_type.shape.dim]) for v in vis
        ]

    double = onnx.TensorProto.DOUBLE
    assert shapes(graph.graph.input) == [(c, double, [1]) for c in spec.channels] + [("state", double, [n_state])]
    assert shapes(graph.graph.output) == [("force", double, [1]), ("state_next", double, [n_state])]
    assert {n.op_type for n in graph.graph.node} <= ALLOWED_OPS
    assert [o.version for o in graph.opset_import if o.domain in ("", "ai.onnx")] == [OPSET]
    assert "step function" in graph.graph.doc_string and "scale_inputs" in {n.name for n in graph.graph.node}


def test_state_holds_physical_delayed_inputs(tmp_path):
    model = make_model(MLP_SPEC, recurrent=False)
    path = export_onnx(model, tmp_path / "m.onnx").path
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    state = np.arange(1.0, 7.0)  # velocity[k-1], velocity[k-2], displacement[k-1..k-3], lowpass[k-1]
    _, state_next = session.run(None, {"velocity": np.array([2.5]), "displacement": np.array([-0.125]), "state": state})
    a = -np.expm1(-T / 0.01)
    np.testing.assert_allclose(state_next, [2.5, 1.0, -0.125, 3.0, 4.0, 6.0 + a * (2.5 - 6.0)], rtol=1e-15)


@pytest.mark.parametrize("recurrent", [False, True], ids=["mlp", "gru"])
def test_component_round_trip_from_file(tmp_path, recurrent):
    spec = MLP_SPEC if not recurrent else GRU_SPEC
    model = make_model(spec, recurrent)
    result = export_onnx(model, tmp_path / "m.onnx", name="damper", description="front damper")
    component = Component.from_onnx(onnx.load(result.path))
    assert component == result.component
    assert [(p.name, p.unit, p.tensor) for p in component.inputs] == [(c, UNITS[c], c) for c in spec.channels]
    assert [(p.min, p.max) for p in component.inputs] == [model.envelope[c] for c in spec.channels]
    assert [(p.name, p.unit) for p in component.outputs] == [("force", "N")]
    (state,) = component.states
    assert (state.input, state.output) == ("state", "state_next")
    assert state.initial == (0.0,) * (spec.state_size + (6 if recurrent else 0))
    assert component.sample_period == T and component.name == "damper" and component.description == "front damper"
    meta = component.metadata
    assert FeatureSpec.from_dict(meta["feature_spec"]) == spec
    assert meta["network"] == {
        "kind": "gru" if recurrent else "mlp",
        "sizes": [spec.n_features, 6 if recurrent else 7, 1],
    }
    assert (
        meta["data_hash"] == "ab" * 32
        and meta["metrics"] == {"test": {"nrmse": 0.05}}
        and meta["training"]["seed"] == 0
    )
    assert [s["name"] for s in meta["state_layout"]][: spec.state_size] == [s.name for s in spec.state_layout()]
    assert meta["training_band"] == {"power_share": 0.99, "upper_edge_Hz": model.band}
    assert meta["max_abs_weight"] == pytest.approx(
        max(float(p.detach().abs().max()) for p in model.network.parameters())
    )


def test_stateless_model_has_no_state_port(tmp_path):
    spec = FeatureSpec(taps=(Tap("velocity"),), output="force", derived=(SmoothSign("velocity"),))
    path = export_onnx(make_model(spec, recurrent=False), tmp_path / "m.onnx").path
    graph = onnx.load(path)
    assert [i.name for i in graph.graph.input] == ["velocity"] and [o.name for o in graph.graph.output] == ["force"]
    assert Component.from_onnx(graph).states == []


def test_failing_verification_writes_nothing(tmp_path):
    model = make_model(MLP_SPEC, recurrent=False)
    exact = model.predict
    model.predict = lambda channels: exact(channels) * (1.0 + 1e-5)  # a torch side that disagrees by 1e-5
    with pytest.raises(ExportError, match="relative error"):
        export_onnx(model, tmp_path / "m.onnx", verify_on=signals(MLP_SPEC.channels, 50, seed=3))
    assert list(tmp_path.iterdir()) == []


def test_hostile_channel_names_survive_export(tmp_path):
    names = ["features", "scale_inputs", "velocity [m/s]", "Δx/ü \"quoted\" 'x'", "one"]
    units = {n: "m/s" for n in names} | {"hidden_gemm": "N"}
    spec = FeatureSpec(
        taps=tuple(Tap(n, (0, 1)) for n in names), output="hidden_gemm", derived=(Lowpass("features", tau=0.01),)
    )
    model = make_model(spec, recurrent=True, units=units)
    test = signals(spec.channels, 100, seed=5)
    result = export_onnx(model, tmp_path / "m.onnx", verify_on=test)
    assert [p.name for p in result.component.inputs] == names
    assert relative(run_step_graph(result.path, test)["hidden_gemm"], model.predict(test)) <= 1e-9


def test_bad_models_raise_naming_the_problem(tmp_path):
    spec = FeatureSpec(taps=(Tap("state", (0, 1)),), output="force")
    with pytest.raises(ExportError, match="'state' clashes"):
        export_onnx(make_model(spec, recurrent=False, units={"state": "m", "force": "N"}), tmp_path / "a.onnx")
    with pytest.raises(ExportError, match="'displacement'"):
        export_onnx(make_model(MLP_SPEC, recurrent=False, units={"velocity": "m/s", "force": "N"}), tmp_path / "b.onnx")
    model = make_model(MLP_SPEC, recurrent=False)
    model.settings = {"lr": float("nan")}
    with pytest.raises(ExportError, match="lr is nan"):
        export_onnx(model, tmp_path / "c.onnx")
    assert list(tmp_path.iterdir()) == []


def test_run_step_graph_handles_a_foreign_graph_without_metadata():
    from onnx import TensorProto, helper

    node = helper.make_node("Mul", ["x", "two"], ["y"])
    graph = helper.make_graph(
        [node],
        "foreign",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, ["batch", 2])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, ["batch", 2])],
        [helper.make_tensor("two", TensorProto.FLOAT, [1], [2.0])],
    )
    foreign = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)])
    foreign.ir_version = 8
    out = run_step_graph(foreign, {"x[0]": np.array([1.0, 2.0]), "x[1]": np.array([-3.0, 0.5])})
    assert sorted(out) == ["y[0]", "y[1]"]
    np.testing.assert_array_equal(out["y[0]"], [2.0, 4.0])
    np.testing.assert_array_equal(out["y[1]"], [-6.0, 1.0])
