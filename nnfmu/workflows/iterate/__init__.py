"""Drive-file iteration on the virtual road test simulator (`nnfmu iterate`): identify, invert, iterate."""

from nnfmu.workflows.iterate.loop import Iteration, Outcome, iterate
from nnfmu.workflows.iterate.run import IterateResult, read_target, run_iterate
from nnfmu.workflows.iterate.settings import (
    ActuatorLimits,
    IterateError,
    IterateSettings,
    parse_band,
    parse_tolerance,
)

__all__ = [
    "ActuatorLimits",
    "IterateError",
    "IterateResult",
    "IterateSettings",
    "Iteration",
    "Outcome",
    "iterate",
    "parse_band",
    "parse_tolerance",
    "read_target",
    "run_iterate",
]
