"""`nnfmu validate`: compare a result file with a reference file into metrics, plots and an HTML report."""

from __future__ import annotations

from nnfmu.validate import Target, ValidationSettings, validate_files

__all__ = ["Target", "ValidationSettings", "validate_files"]
