"""The error `nnfmu build` raises when an FMU cannot be built; the message names the file, port, node or command."""

from __future__ import annotations


class FmuBuildError(Exception):
    """Building an FMU failed; no `.fmu` was written."""


class CompilerError(FmuBuildError):
    """The C compiler is missing or rejected the FMU's sources (its output is in the message)."""
