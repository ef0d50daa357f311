"""The loop driver's exception: unusable data or model for `nnfmu loop` (a bad residual is the diagnosis's
`DiagnosisError`, raised by `nnfmu.diagnosis` and passed through)."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class LoopError(NnfmuError, ValueError):
    """The loop cannot run on this data or model; the message names the file, channel or value at fault."""
