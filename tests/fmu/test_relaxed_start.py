"""A network whose features start relaxed at the first input (`FeatureSpec.relaxed_start`, the bushing presets'
default): its FMU, started by a plain master at its default parameters on a deflected input, computes what its
step graph computes in onnxruntime and what the trained model predicts from the same relaxed start; the FMU of the
same network without the option starts from rest and differs."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import onnx
import pytest
from exported_networks import FORCE, T, export_network, signals

from nnfmu.cosim.replay import replay_fmu
from nnfmu.data import Measurement
from nnfmu.export.step_runner import run_step_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.models.features import Stop

RELAXED = replace(
    FORCE, derived=(*FORCE.derived, Stop("axial_displacement", radius=0.004)), relaxed_start=True
)  # a delay line, a low-pass and a stop operator, all started at the first input


def deflected(n: int) -> Measurement:
    """Held-out-like inputs about a static deflection far outside the stop's radius (a car standing on its bushing)."""
    channels = signals(RELAXED.channels, n, 11)
    channels["axial_displacement"] = 0.05 + channels["axial_displacement"]
    units = {"axial_displacement": "m", "axial_velocity": "m/s"}
    return Measurement(np.arange(n) * T, channels, units, source="deflected inputs")


@pytest.fixture(scope="module")
def networks(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("relaxed")
    return {
        "relaxed": export_network(RELAXED, folder / "relaxed.onnx", 3),
        "rest": export_network(replace(RELAXED, relaxed_start=False), folder / "rest.onnx", 3),
    }


@pytest.mark.slow
@pytest.mark.parametrize(("fmi", "backend"), [(2, "native"), (3, "native"), (2, "pythonfmu")])
def test_fmu_started_deflected_equals_the_relaxed_step_graph(networks, tmp_path, fmi, backend):
    inputs = deflected(300)
    fmu = build_fmu(networks["relaxed"], BuildOptions(out=tmp_path / "relaxed.fmu", fmi_version=fmi, backend=backend))
    replayed = replay_fmu(fmu, inputs)["axial_force"]
    graph = run_step_graph(onnx.load(networks["relaxed"]), inputs.channels)["axial_force"]
    np.testing.assert_allclose(replayed, graph, rtol=1e-12, atol=1e-12 * np.max(np.abs(graph)))


def test_relaxed_step_graph_equals_the_trained_model_from_the_same_start(networks):
    """The graph's own first-sample relaxation matches training's (numpy features from the relaxed state)."""
    import torch

    from nnfmu.models.networks import MLP
    from nnfmu.models.scaling import MinMaxScaler
    from nnfmu.models.trained import TrainedModel

    inputs = deflected(300)
    graph = run_step_graph(onnx.load(networks["relaxed"]), inputs.channels)["axial_force"]
    # rebuild the same random network as export_network(seed 3) and predict through the numpy features
    torch.manual_seed(3)
    network = MLP(RELAXED.n_features, 5)
    with torch.no_grad():
        for p in network.parameters():
            p.mul_(3.0)
    train = signals(RELAXED.channels, 400, 3)
    model = TrainedModel(
        spec=RELAXED,
        network=network,
        feature_scaler=MinMaxScaler.fit(RELAXED.features(train, T)),
        target_scaler=MinMaxScaler.fit(np.random.default_rng(3).normal(scale=500.0, size=400)),
        sample_period=T,
        units={},
        envelope={},
        metrics={},
        data_hash="",
        settings={},
    )
    np.testing.assert_allclose(model.predict(inputs.channels), graph, rtol=1e-9, atol=1e-9 * np.max(np.abs(graph)))


@pytest.mark.slow
def test_the_same_network_from_rest_starts_loaded(networks, tmp_path):
    """Without the option the FMU starts every slot at zero: the stop operator is loaded by the deflection and the
    low-pass rises from zero, so the outputs differ at the start (what a car standing on the bushing must not see)."""
    inputs = deflected(300)
    outputs = {
        name: replay_fmu(build_fmu(path, BuildOptions(out=tmp_path / f"{name}.fmu")), inputs)["axial_force"]
        for name, path in networks.items()
    }
    graph = run_step_graph(onnx.load(networks["rest"]), inputs.channels)["axial_force"]
    np.testing.assert_allclose(outputs["rest"], graph, rtol=1e-12, atol=1e-12 * np.max(np.abs(graph)))
    assert np.max(np.abs(outputs["relaxed"][:20] - outputs["rest"][:20])) > 1e-3 * np.max(np.abs(outputs["rest"]))
