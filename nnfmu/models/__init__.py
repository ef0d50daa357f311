"""Networks from rig data: feature specs, presets, training (Levenberg–Marquardt, Adam, L-BFGS), metrics, input
selection, and the `train` workflow (`nnfmu.models.workflow`, imported on use: it pulls in the exporter)."""

from __future__ import annotations

from typing import Any

from nnfmu.models.metrics import SplitMetrics
from nnfmu.models.presets import PRESETS, Preset, get_preset
from nnfmu.models.selection import SelectionResult, SelectionSettings, select_inputs
from nnfmu.models.splits import SplitFractions
from nnfmu.models.train import Architecture, TrainResult, TrainSettings, train_model

__all__ = [
    "PRESETS",
    "Architecture",
    "Preset",
    "SelectionResult",
    "SelectionSettings",
    "SplitFractions",
    "SplitMetrics",
    "TrainOutcome",
    "TrainRequest",
    "TrainResult",
    "TrainSettings",
    "get_preset",
    "select_inputs",
    "train_from_file",
    "train_model",
]


def __getattr__(name: str) -> Any:
    if name in ("TrainOutcome", "TrainRequest", "train_from_file"):
        from nnfmu.models import workflow

        return getattr(workflow, name)
    raise AttributeError(f"module 'nnfmu.models' has no attribute {name!r}")
