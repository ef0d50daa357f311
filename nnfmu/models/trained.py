"""A trained component network with everything the exporter needs: feature spec, scalers, units, envelope, metrics."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from nnfmu.models.features import FeatureSpec
from nnfmu.models.networks import GRUNet, MLP
from nnfmu.models.scaling import MinMaxScaler


@dataclass
class TrainedModel:
    """A network plus the context that makes it a component model.

    `feature_scaler` maps the spec's feature columns to [-1, 1]; `target_scaler` the output channel.
    `units` holds the SI unit of every input channel and of the output; `envelope` the (min, max) of every input
    channel over the training data; `metrics` maps split name ("train", "validation", "test") to metric values.
    """

    spec: FeatureSpec
    network: MLP | GRUNet
    feature_scaler: MinMaxScaler
    target_scaler: MinMaxScaler
    sample_period: float
    units: dict[str, str]
    envelope: dict[str, tuple[float, float]]
    metrics: dict[str, dict[str, float]] = field(default_factory=dict)
    data_hash: str = ""
    settings: dict[str, Any] = field(default_factory=dict)

    def predict(self, channels: dict[str, np.ndarray]) -> np.ndarray:
        """Simulate the model sample by sample from rest over the given input channels -> output (n,) in SI units."""
        features = self.spec.features(channels, self.sample_period)
        scaled = torch.from_numpy(self.feature_scaler.scale(features))
        self.network.eval()
        with torch.no_grad():
            if isinstance(self.network, GRUNet):
                out = self.network(scaled.unsqueeze(0))[0, :, 0]
            else:
                out = self.network(scaled)[:, 0]
        return self.target_scaler.unscale(out.numpy())
