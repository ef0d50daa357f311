"""Closing the loop, the driver: replay a model's FMU on measured data, diagnose the residual (`nnfmu.diagnosis`),
extend the feature spec with the top effect's extension, retrain the rivals, rebuild and replay; then the report."""

from .blocks import RecordBlocks, part_measurement, plan_blocks, training_part
from .errors import LoopError
from .results import Iteration, LoopReport
from .run import run_loop
from .settings import LoopSettings

__all__ = [
    "Iteration",
    "LoopError",
    "LoopReport",
    "LoopSettings",
    "RecordBlocks",
    "part_measurement",
    "plan_blocks",
    "run_loop",
    "training_part",
]
