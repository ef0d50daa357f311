"""Read an nnfmu ONNX step graph back into a trainable model: feature spec and training settings from its metadata,
weights and scalers from the initializers the exporter wrote (`initializers.py`), so that a model can be extended and
retrained by a process that did not make it (the loop)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import onnx
import torch
from onnx import numpy_helper

from nnfmu.component import Component
from nnfmu.export.band import carried_band
from nnfmu.export.errors import ExportError
from nnfmu.export.initializers import (
    FEATURE_GAIN,
    FEATURE_MIN,
    MLP_INITIALIZERS,
    SCALER_INITIALIZERS,
    TARGET_GAIN,
    TARGET_MIN,
)
from nnfmu.models.features import FeatureSpec
from nnfmu.models.networks import MLP
from nnfmu.models.scaling import MinMaxScaler
from nnfmu.models.trained import TrainedModel


def _scaler(low: np.ndarray, gain: np.ndarray) -> MinMaxScaler:
    """The scaler with these extremes: hi = lo + 2/gain (a constant column was stored with gain 1)."""
    low, gain = np.ravel(low).astype(float), np.ravel(gain).astype(float)
    return MinMaxScaler(lo=low, hi=low + 2.0 / gain)


def read_step_graph(path: str | os.PathLike[str]) -> tuple[TrainedModel, Component]:
    """(the MLP step graph at `path` as a TrainedModel, its Component). ExportError names what is missing or wrong:
    no file, malformed or no nnfmu metadata (another tool's graph has no feature spec), a recurrent network, or an
    initializer the exporter writes."""
    path = Path(path)
    if not path.is_file():
        raise ExportError(f"{path}: no such model file")
    try:
        graph = onnx.load(str(path))
    except Exception as err:  # onnx raises DecodeError, ValueError and others for a file that is not ONNX
        raise ExportError(f"{path}: not a readable ONNX file ({err})") from None
    try:
        component = Component.from_onnx(graph)
    except (ValueError, KeyError, TypeError) as err:  # malformed or too new `nnfmu.component` metadata
        raise ExportError(f"{path}: cannot read the component description: {err}") from None
    meta = component.metadata
    if "feature_spec" not in meta or "network" not in meta:
        raise ExportError(
            f"{path}: no nnfmu feature spec in the ONNX metadata: only graphs exported by nnfmu "
            "(`nnfmu train`) say which features and network they hold"
        )
    kind = meta["network"].get("kind")
    if kind != "mlp":
        raise ExportError(f"{path}: network kind {kind!r}; only MLP step graphs are read back into a model")
    try:
        spec = FeatureSpec.from_dict(meta["feature_spec"])
    except ValueError as err:
        raise ExportError(f"{path}: cannot read the feature spec: {err}") from None
    tensors = {t.name: numpy_helper.to_array(t) for t in graph.graph.initializer}
    absent = [name for name in (*MLP_INITIALIZERS, *SCALER_INITIALIZERS) if name not in tensors]
    if absent:
        raise ExportError(f"{path}: initializer(s) {', '.join(absent)} missing; not an nnfmu MLP step graph")
    w1, b1, w2, b2 = (np.array(tensors[name], dtype=float) for name in MLP_INITIALIZERS)
    if w1.shape[1] != spec.n_features:
        raise ExportError(f"{path}: hidden weights take {w1.shape[1]} features, the feature spec has {spec.n_features}")
    network = MLP(w1.shape[1], w1.shape[0], w2.shape[0])
    with torch.no_grad():
        for parameter, value in zip(network.parameters(), (w1, b1, w2, b2)):
            parameter.copy_(torch.from_numpy(value.reshape(parameter.shape)))
    if component.sample_period is None:
        raise ExportError(f"{path}: the component has no sample period")
    ports = {p.name: p for p in component.inputs}
    units = {p.name: p.unit for p in (*component.inputs, *component.outputs)}
    envelope = {
        name: (float(p.min if p.min is not None else -np.inf), float(p.max if p.max is not None else np.inf))
        for name, p in ports.items()
    }
    model = TrainedModel(
        spec=spec,
        network=network,
        feature_scaler=_scaler(tensors[FEATURE_MIN], tensors[FEATURE_GAIN]),
        target_scaler=_scaler(tensors[TARGET_MIN], tensors[TARGET_GAIN]),
        sample_period=float(component.sample_period),
        units=units,
        envelope=envelope,
        metrics=dict(meta.get("metrics", {})),
        data_hash=str(meta.get("data_hash", "")),
        settings=dict(meta.get("training", {})),
        band=carried_band(component),
    )
    return model, component
