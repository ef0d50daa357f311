"""The exception raised when a model cannot be exported or its exported graph disagrees with the model."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class ExportError(NnfmuError, ValueError):
    """Export failed; the message names the node, channel or value and the measured disagreement."""
