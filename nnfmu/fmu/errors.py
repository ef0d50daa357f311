"""The error `nnfmu build` raises when an FMU cannot be built; the message names the file, port, node or command."""

from __future__ import annotations

from nnfmu.errors import NnfmuError


class FmuBuildError(NnfmuError):
    """Building an FMU failed; no `.fmu` was written."""


class CompilerError(FmuBuildError):
    """The C compiler is missing or rejected the FMU's sources (its output is in the message)."""


class PlatformSkippedWarning(UserWarning):
    """A default build left out a platform whose compiler is missing (the FMU still has this machine's binary)."""
