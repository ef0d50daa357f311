"""The exception raised when a pythonfmu FMU cannot be built, so callers can tell it from programming errors."""

from __future__ import annotations

from nnfmu.fmu.errors import FmuBuildError


class PythonFmuBuildError(FmuBuildError):
    """A pythonfmu FMU cannot be built from this graph or with these options; the message says which and why."""
