"""Small exported networks for the FMU tests: random-weight MLPs (tanh units in their nonlinear range) on bushing
channels, exported by `export_onnx` with held-out inputs, so the graphs carry nnfmu's full metadata and a reference
stimulus like a trained model's. Needs torch (the test extras have it); no training."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from nnfmu.export import export_onnx
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
HELD_OUT_SEED_OFFSET = 100


def signals(channels: list[str], n: int, seed: int) -> dict[str, np.ndarray]:
    """Sines with noise, one per channel, of growing amplitude."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * T
    return {
        c: (0.01 + i) * (np.sin(2 * np.pi * rng.uniform(1, 9) * t + rng.uniform(0, 6)) + 0.2 * rng.normal(size=n))
        for i, c in enumerate(channels)
    }


def random_model(spec: FeatureSpec, seed: int) -> TrainedModel:
    """A random-weight network on `spec` with scalers fitted to `signals` of `seed`: a trained model's shape."""
    torch.manual_seed(seed)
    network = MLP(spec.n_features, 5)
    with torch.no_grad():
        for p in network.parameters():
            p.mul_(3.0)
    train = signals(spec.channels, 400, seed)
    return TrainedModel(
        spec=spec,
        network=network,
        feature_scaler=MinMaxScaler.fit(spec.features(train, T)),
        target_scaler=MinMaxScaler.fit(np.random.default_rng(seed).normal(scale=500.0, size=400)),
        sample_period=T,
        units=UNITS,
        envelope={c: (float(train[c].min()), float(train[c].max())) for c in spec.channels},
        metrics={"test": {"nrmse": 0.1}},
        data_hash="ab" * 32,
        settings={"seed": seed},
    )


def export_network(spec: FeatureSpec, path: Path, seed: int) -> Path:
    """A random-weight network on `spec` exported to `path` with held-out inputs (`signals` of seed + 100)."""
    model = random_model(spec, seed)
    held_out = signals(spec.channels, 700, seed + HELD_OUT_SEED_OFFSET)
    return export_onnx(model, path, name=f"{spec.output}_net", verify_on=held_out).path
