"""The `Component` an exported step graph carries: ports with units and envelope, state, sample period, provenance."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import PurePath
from typing import Any

import numpy as np

import nnfmu
from nnfmu.component import Component, Port, StatePort
from nnfmu.data.band import BAND_POWER_SHARE
from nnfmu.export.band import TRAINING_BAND
from nnfmu.export.errors import ExportError
from nnfmu.export.networks import max_abs_weight
from nnfmu.export.step_graph import STATE, STATE_NEXT, network_sizes, state_layout
from nnfmu.models.trained import TrainedModel


def jsonable(value: Any, where: str) -> Any:
    """`value` as plain JSON data (numpy numbers, tuples and paths converted); NaN/Inf or objects raise ExportError."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [jsonable(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, PurePath):
        return str(value)
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            raise ExportError(f"{where} is {value}; metadata must be finite numbers")
        return float(value)
    if value is None or isinstance(value, str):
        return value
    raise ExportError(f"{where} has type {type(value).__name__}, which cannot be stored as JSON metadata")


def _unit(model: TrainedModel, channel: str) -> str:
    if channel not in model.units:
        raise ExportError(f"no unit given for channel {channel!r} (units: {sorted(model.units)})")
    return model.units[channel]


def _input_port(model: TrainedModel, channel: str) -> Port:
    if channel not in model.envelope:
        raise ExportError(f"no training envelope for input channel {channel!r}")
    lo, hi = (float(v) for v in model.envelope[channel])
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ExportError(f"training envelope of {channel!r} is not a finite interval: ({lo}, {hi})")
    unit = _unit(model, channel)
    return Port(name=channel, unit=unit, description=f"{channel} [{unit}] at the current sample", min=lo, max=hi)


def build_component(model: TrainedModel, name: str, description: str) -> Component:
    """Describe the step graph of `model` for ONNX metadata, model description and FMU configuration."""
    spec = model.spec
    kind, sizes = network_sizes(model)
    layout = state_layout(model)
    out_unit = _unit(model, spec.output)
    states = []
    if layout:
        summary = ", ".join(slot.name for slot in layout)
        initial = tuple(slot.initial for slot in layout)
        states.append(StatePort(STATE, STATE_NEXT, initial, description=f"state: {summary}"))
    metadata = {
        "nnfmu_version": nnfmu.__version__,
        "data_hash": model.data_hash,
        "feature_spec": spec.to_dict(),
        "network": {"kind": kind, "sizes": sizes},
        "state_layout": [
            {
                "name": s.name,
                "unit": model.units.get(s.channel, "1"),
                "initial": s.initial,
                "description": s.description,
            }
            for s in layout
        ],
        "training": model.settings,
        "metrics": model.metrics,
        "max_abs_weight": max_abs_weight(model.network),
    }
    if model.band:
        metadata[TRAINING_BAND] = {"power_share": BAND_POWER_SHARE, "upper_edge_Hz": dict(model.band)}
    return Component(
        name=name,
        inputs=[_input_port(model, c) for c in spec.channels],
        outputs=[Port(spec.output, out_unit, f"{spec.output} [{out_unit}] predicted by the {kind.upper()} network")],
        states=states,
        sample_period=float(model.sample_period),
        description=description,
        metadata=jsonable(metadata, "metadata"),
    )
