"""Closing the loop, the driver: replay a model's FMU on measured data, diagnose the residual (`nnfmu.diagnosis`),
extend the feature spec with the top effect's extension, retrain the rivals, rebuild and replay; then the report."""

from nnfmu.workflows.loop.blocks import RecordBlocks, part_measurement, plan_blocks, training_part
from nnfmu.workflows.loop.errors import LoopError
from nnfmu.workflows.loop.results import Iteration, LoopReport
from nnfmu.workflows.loop.run import run_loop
from nnfmu.workflows.loop.settings import LoopSettings

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
