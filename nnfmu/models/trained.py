"""A trained component network with everything the exporter needs: feature spec, scalers, units, envelope, metrics."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from nnfmu.data import Measurement
from nnfmu.data.band import excited_band
from nnfmu.models.features import FeatureSpec
from nnfmu.models.networks import MLP, GRUNet
from nnfmu.models.scaling import MinMaxScaler


@dataclass
class TrainedModel:
    """A network plus the context that makes it a component model.

    `feature_scaler` maps the spec's feature columns to [-1, 1]; `target_scaler` the output channel.
    `units` holds the SI unit of every input channel and of the output; `envelope` the (min, max) of every input
    channel over the training data; `band` the upper edge [Hz] of the frequency band each input channel's training
    record excites (`excited_band`; empty: not known, e.g. a model read back from an older file); `metrics` maps split
    name ("train", "validation", "test") to metric values.
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
    band: dict[str, float] = field(default_factory=dict)

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
    earlier_band: Mapping[str, float] | None = None,
) -> TrainedModel:
    """The one way a fit becomes a TrainedModel (a first fit and a retraining alike): units and the data hash from the
    measurement, each input's envelope over the training rows and the band its record excites (the whole record: the
    training rows are blocks spread over it), each widened by `earlier_envelope` and `earlier_band` where they have
    the channel (a retrained model keeps what its predecessor was trained on)."""
    envelope, band = {}, {}
    for c in spec.channels:
        lo, hi = float(np.min(measurement[c][train_rows])), float(np.max(measurement[c][train_rows]))
        if earlier_envelope is not None and c in earlier_envelope:
            lo, hi = min(lo, earlier_envelope[c][0]), max(hi, earlier_envelope[c][1])
        envelope[c] = (lo, hi)
        band[c] = max(excited_band(measurement[c], sample_period), (earlier_band or {}).get(c, 0.0))
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
        band=band,
    )
