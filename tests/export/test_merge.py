"""Merging step graphs: the merged graph reproduces every part exactly in onnxruntime; bad merges name the problem."""

from __future__ import annotations

import numpy as np
import onnx
import pytest
import torch

from nnfmu.component import Component
from nnfmu.cosim.replay import replay_fmu
from nnfmu.data import Measurement
from nnfmu.export import export_onnx, run_step_graph
from nnfmu.export.graph import ALLOWED_OPS
from nnfmu.export.merge import MergeError, merge_step_graphs
from nnfmu.export.own_error import carried_own_errors
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.models.features import FeatureSpec, Lowpass, Tap
from nnfmu.models.networks import MLP
from nnfmu.models.scaling import MinMaxScaler
from nnfmu.models.trained import TrainedModel

T = 0.001
UNITS = {
    "axial_displacement": "m",
    "axial_velocity": "m/s",
    "axial_force": "N",
    "axial_rotation": "rad",
    "axial_angular_velocity": "rad/s",
    "axial_torque": "N.m",
}
FORCE = FeatureSpec(
    taps=(Tap("axial_displacement", (0, 1)), Tap("axial_velocity")),
    output="axial_force",
    derived=(Lowpass("axial_displacement", tau=0.01),),
)
TORQUE = FeatureSpec(
    taps=(Tap("axial_rotation", (0, 1, 2)), Tap("axial_angular_velocity", (0, 1))), output="axial_torque"
)
STATELESS = FeatureSpec(taps=(Tap("axial_velocity"),), output="axial_torque")


def signals(channels: list[str], n: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * T
    return {
        c: (0.01 + i) * (np.sin(2 * np.pi * rng.uniform(1, 9) * t + rng.uniform(0, 6)) + 0.2 * rng.normal(size=n))
        for i, c in enumerate(channels)
    }


def exported(spec: FeatureSpec, path, seed: int, period: float = T) -> onnx.ModelProto:
    """A random-weight network on `spec` (tanh units in their nonlinear range), exported as a step graph."""
    torch.manual_seed(seed)
    network = MLP(spec.n_features, 5)
    with torch.no_grad():
        for p in network.parameters():
            p.mul_(3.0)
    train = signals(spec.channels, 400, seed)
    model = TrainedModel(
        spec=spec,
        network=network,
        feature_scaler=MinMaxScaler.fit(spec.features(train, period)),
        target_scaler=MinMaxScaler.fit(np.random.default_rng(seed).normal(scale=500.0, size=400)),
        sample_period=period,
        units=UNITS,
        envelope={c: (float(train[c].min()), float(train[c].max())) for c in spec.channels},
        metrics={"test": {"nrmse": 0.1}},
        data_hash="cd" * 32,
        settings={"seed": seed},
        band={c: 20.0 + seed + i for i, c in enumerate(spec.channels)},
    )
    return onnx.load(export_onnx(model, path, name=f"{spec.output}_{seed}").path)


@pytest.fixture(scope="module")
def parts(tmp_path_factory: pytest.TempPathFactory) -> list[onnx.ModelProto]:
    folder = tmp_path_factory.mktemp("merge")
    return [exported(FORCE, folder / "force.onnx", 1), exported(TORQUE, folder / "torque.onnx", 2)]


def test_merged_graph_reproduces_each_part_exactly(parts: list[onnx.ModelProto]) -> None:
    merged = merge_step_graphs(parts, "bushing", "force and torque")
    component = Component.from_onnx(merged)
    assert [p.name for p in component.outputs] == ["axial_force", "axial_torque"]
    assert component.state_size == sum(Component.from_onnx(p).state_size for p in parts) > 0
    assert {n.op_type for n in merged.graph.node} <= ALLOWED_OPS
    channels = signals([p.name for p in component.inputs], 600, 7)
    together = run_step_graph(merged, channels)
    for part in parts:
        alone = run_step_graph(part, channels)
        for name, values in alone.items():
            np.testing.assert_array_equal(together[name], values)


def test_shared_inputs_are_one_port_with_the_common_envelope(tmp_path) -> None:
    first = exported(FORCE, tmp_path / "a.onnx", 3)
    second = exported(FeatureSpec(taps=FORCE.taps, output="axial_torque"), tmp_path / "b.onnx", 4)
    merged = merge_step_graphs([first, second], "shared")
    ports = {p.name: p for p in Component.from_onnx(merged).inputs}
    assert sorted(ports) == ["axial_displacement", "axial_velocity"]
    for name, port in ports.items():
        envelopes = [next(p for p in Component.from_onnx(m).inputs if p.name == name) for m in (first, second)]
        assert port.min == max(e.min for e in envelopes) and port.max == min(e.max for e in envelopes)
    channels = signals(sorted(ports), 300, 5)
    together = run_step_graph(merged, channels)
    np.testing.assert_array_equal(together["axial_force"], run_step_graph(first, channels)["axial_force"])
    np.testing.assert_array_equal(together["axial_torque"], run_step_graph(second, channels)["axial_torque"])


def test_a_merged_graph_carries_the_band_every_part_trusts(tmp_path) -> None:
    """Per input the lowest edge of the parts that take it, as the envelope is their intersection; nothing when a
    part carries no band."""
    first = exported(FORCE, tmp_path / "a.onnx", 3)
    second = exported(FeatureSpec(taps=FORCE.taps, output="axial_torque"), tmp_path / "b.onnx", 4)
    part = Component.from_onnx(second)
    edges = dict(part.metadata["training_band"]["upper_edge_Hz"], axial_velocity=12.0)
    part.metadata["training_band"]["upper_edge_Hz"] = edges
    part.attach_to(second)
    merged = Component.from_onnx(merge_step_graphs([first, second], "shared")).metadata["training_band"]
    first_edges = Component.from_onnx(first).metadata["training_band"]["upper_edge_Hz"]
    assert first_edges["axial_velocity"] > 12.0
    assert merged == {
        "power_share": 0.99,
        "upper_edge_Hz": {name: min(edge, edges[name]) for name, edge in first_edges.items()},
    }
    del part.metadata["training_band"]
    part.attach_to(second)
    assert "training_band" not in Component.from_onnx(merge_step_graphs([first, second], "shared")).metadata


def test_a_merged_graph_keeps_each_parts_own_error(tmp_path) -> None:
    """A bushing FMU of merged networks judges each output by the own error of the network that gives it."""
    graphs = [exported(FORCE, tmp_path / "a.onnx", 5), exported(TORQUE, tmp_path / "b.onnx", 6)]
    for graph, rms in zip(graphs, (3.0, 0.2)):
        part = Component.from_onnx(graph)
        part.metadata["metrics"] = {"test": {"nrmse": 0.1, "rms_error": rms}}
        part.attach_to(graph)
    own = carried_own_errors(Component.from_onnx(merge_step_graphs(graphs, "both")))
    assert {name: (o.unit, o.rms_error) for name, o in own.items()} == {
        "axial_force": ("N", 3.0),
        "axial_torque": ("N.m", 0.2),
    }


def test_merged_native_fmu_with_a_stateless_part_matches_onnxruntime(parts: list[onnx.ModelProto], tmp_path) -> None:
    stateless = exported(STATELESS, tmp_path / "stateless.onnx", 6)
    assert Component.from_onnx(stateless).state_size == 0
    merged = merge_step_graphs([parts[0], stateless], "bushing")
    path = tmp_path / "bushing.onnx"
    onnx.save(merged, path)
    fmu = build_fmu(path, BuildOptions(out=tmp_path / "bushing.fmu"))
    component = Component.from_onnx(merged)
    channels = signals([p.name for p in component.inputs], 400, 8)
    time = np.arange(400) * T
    units = {p.name: p.unit for p in component.inputs}
    replayed = replay_fmu(fmu, Measurement(time=time, channels=channels, units=units, source="merge test"))
    expected = run_step_graph(merged, channels)
    for name in ("axial_force", "axial_torque"):
        scale = np.max(np.abs(expected[name]))
        assert np.max(np.abs(replayed[name] - expected[name])) <= 1e-9 * scale


def test_bad_merges_name_the_problem(parts: list[onnx.ModelProto], tmp_path) -> None:
    slow = exported(TORQUE, tmp_path / "slow.onnx", 2, period=2 * T)
    with pytest.raises(MergeError, match="sample periods differ"):
        merge_step_graphs([parts[0], slow], "bad")
    with pytest.raises(MergeError, match="output tensor 'axial_force'"):
        merge_step_graphs([parts[0], parts[0]], "twice")
    with pytest.raises(MergeError, match="no step graphs"):
        merge_step_graphs([], "empty")
    foreign = onnx.ModelProto()
    foreign.CopyFrom(parts[1])
    del foreign.metadata_props[:]
    with pytest.raises(MergeError, match="no nnfmu component description"):
        merge_step_graphs([parts[0], foreign], "foreign")
