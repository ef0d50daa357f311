"""The outcome of a co-simulation run and its file: every FMU output over time, with units, as CSV or MDF 4."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from nnfmu.data import Measurement, save_measurement


@dataclass
class CosimResult:
    """Outputs labelled with the time they belong to (row n: t_n = t0 + n h), and how the coupling went.

    `steps` communication steps were taken; `passes` counts every (re)step of the whole system, so
    passes / steps - 1 is the mean number of coupling iterations; `unconverged_steps` counts steps whose fixed point
    was not reached within the allowed iterations; `master` names the master that produced the result.
    """

    measurement: Measurement
    steps: int
    passes: int
    unconverged_steps: int
    master: str

    @property
    def mean_iterations(self) -> float:
        return self.passes / self.steps - 1.0 if self.steps else 0.0


def save_result(result: CosimResult, path: str | os.PathLike[str]) -> Path:
    """Write the result's channels with units (`name [unit]` headers) to `.csv` or `.mf4`; return the path."""
    return save_measurement(result.measurement, path)
