"""ONNX export: a trained model becomes one self-contained, float64 step graph with its `Component` in the metadata.

`run_step_graph` and `ExportError` need no torch and are imported eagerly; `export_onnx` and `read_step_graph` (its
inverse for MLP graphs; both need torch through the trained model) are imported on first use so FMU-side code can
use this package without torch.
"""

from __future__ import annotations

from typing import Any

from nnfmu.export.errors import ExportError
from nnfmu.export.step_runner import run_step_graph

__all__ = ["ExportError", "ExportResult", "export_onnx", "read_step_graph", "run_step_graph"]


def __getattr__(name: str) -> Any:
    if name in ("export_onnx", "ExportResult"):
        from nnfmu.export import exporter

        return getattr(exporter, name)
    if name == "read_step_graph":
        from nnfmu.export.read import read_step_graph

        return read_step_graph
    raise AttributeError(f"module 'nnfmu.export' has no attribute {name!r}")
