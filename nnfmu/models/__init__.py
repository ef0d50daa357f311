"""Networks from rig data: feature specs, presets, training (Levenberg–Marquardt, Adam, L-BFGS), metrics, input
selection. The `nnfmu train` use case (load, train, export) is `nnfmu.workflows.train`.

Every name here is imported on first use, so that `nnfmu.models.features` (numpy only) can be imported without
torch: the torch-free diagnosis library (`nnfmu.diagnosis`) builds feature specs from it.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from nnfmu.models.metrics import SplitMetrics
    from nnfmu.models.presets import PRESETS, Preset, get_preset
    from nnfmu.models.selection import SelectionResult, SelectionSettings, select_inputs
    from nnfmu.models.splits import SplitFractions
    from nnfmu.models.train import Architecture, TrainResult, TrainSettings, train_model

_HOMES = {
    "SplitMetrics": "metrics",
    "PRESETS": "presets",
    "Preset": "presets",
    "get_preset": "presets",
    "SelectionResult": "selection",
    "SelectionSettings": "selection",
    "select_inputs": "selection",
    "SplitFractions": "splits",
    "Architecture": "train",
    "TrainResult": "train",
    "TrainSettings": "train",
    "train_model": "train",
}

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


def __getattr__(name: str) -> Any:
    """The public name `name` from the module that defines it, imported now."""
    if name in _HOMES:
        return getattr(import_module(f"nnfmu.models.{_HOMES[name]}"), name)
    raise AttributeError(f"module 'nnfmu.models' has no attribute {name!r}")
