"""A trained component network with everything the exporter needs: feature spec, scalers, units, envelope, metrics."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from nnfmu.data import Measurement
from nnfmu.models.features import FeatureSpec
from nnfmu.models.networks import MLP, GRUNet
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


def data_hash(measurement: Measurement, names: list[str]) -> str:
    """SHA-256 over the named channels' names and float64 values (the training data's fingerprint)."""
    digest = hashlib.sha256()
    for name in names:
        digest.update(name.encode("utf-8") + b"\0")
        digest.update(np.ascontiguousarray(measurement[name], dtype=np.float64).tobytes())
    return digest.hexdigest()


def trained_model(
    spec: FeatureSpec,
    network: MLP | GRUNet,
    feature_scaler: MinMaxScaler,
    target_scaler: MinMaxScaler,
    measurement: Measurement,
    train_rows: np.ndarray,
    sample_period: float,
    metrics: dict[str, dict[str, float]],
    settings: dict[str, Any],
    earlier_envelope: Mapping[str, tuple[float, float]] | None = None,
) -> TrainedModel:
    """The one way a fit becomes a TrainedModel (a first fit and a retraining alike): units and the data hash from the
    measurement, each input's envelope over the training rows (widened by `earlier_envelope` where it has the
    channel: a retrained model keeps the range its predecessor was trained on)."""
    envelope = {}
    for c in spec.channels:
        lo, hi = float(np.min(measurement[c][train_rows])), float(np.max(measurement[c][train_rows]))
        if earlier_envelope is not None and c in earlier_envelope:
            lo, hi = min(lo, earlier_envelope[c][0]), max(hi, earlier_envelope[c][1])
        envelope[c] = (lo, hi)
    return TrainedModel(
        spec=spec,
        network=network,
        feature_scaler=feature_scaler,
        target_scaler=target_scaler,
        sample_period=sample_period,
        units={c: measurement.units[c] for c in (*spec.channels, spec.output)},
        envelope=envelope,
        metrics=metrics,
        data_hash=data_hash(measurement, [*spec.channels, spec.output]),
        settings=settings,
    )
