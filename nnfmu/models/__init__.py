"""Networks from rig data: feature specs, presets, training (Levenberg–Marquardt, Adam, L-BFGS), metrics, input
selection. The `nnfmu train` use case (load, train, export) is `nnfmu.workflows.train`."""

from __future__ import annotations

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
    "TrainResult",
    "TrainSettings",
    "get_preset",
    "select_inputs",
    "train_model",
]

