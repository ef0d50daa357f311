"""The exception raised when a residual cannot be diagnosed, so callers can tell bad input from programming errors."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class DiagnosisError(NnfmuError, ValueError):
    """Unusable input to the diagnosis; the message names the source, channel or value and what was expected."""
