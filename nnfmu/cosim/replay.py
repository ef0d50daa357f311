"""Replay measured inputs through a component FMU, sample by sample, to compare its outputs with the measurement.

Because the inputs of a measurement are known in advance, the replay sets the input of sample k before the step that
ends at t_k, so the FMU output at t_k is the network's response to the inputs at t_k (no communication delay), as in
the network's training. Sample 0 is evaluated when initialisation ends.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nnfmu.component import same_period
from nnfmu.cosim.slave import FmuSlave
from nnfmu.data.measurement import Measurement
from nnfmu.errors import NnfmuError


class ReplayError(NnfmuError, ValueError):
    """The measurement cannot drive the FMU (missing input channel, other sample rate, ...)."""


@dataclass(frozen=True)
class ReplaySettings:
    """Parameters set before initialisation: filter_cutoff [Hz] (the output low-pass, 0: off) and output_gain [1];
    None keeps the FMU's start value, so a replay at the defaults sees what any plain master gets."""

    filter_cutoff: float | None = None
    output_gain: float | None = None

    def parameters(self) -> dict[str, float]:
        """The parameters to set, by name (those left at None are not set)."""
        chosen = {"filter_cutoff": self.filter_cutoff, "output_gain": self.output_gain}
        return {name: float(value) for name, value in chosen.items() if value is not None}


def replay_fmu(
    fmu_path: str | Path, measurement: Measurement, settings: ReplaySettings = ReplaySettings()
) -> Measurement:
    """Drive the FMU with the measured channels named like its inputs; return its outputs on the measurement's time."""
    with FmuSlave(fmu_path, instance_name=Path(fmu_path).stem) as slave:
        inputs = slave.names("input")
        missing = [name for name in inputs if name not in measurement]
        if missing:
            raise ReplayError(
                f"{measurement.source}: no channel {', '.join(map(repr, missing))} for the inputs of "
                f"{fmu_path} (the measurement has: {', '.join(measurement.names)})"
            )
        dt = measurement.sample_period
        period = slave.sample_period
        if period is not None and not same_period(period, dt):
            raise ReplayError(
                f"{measurement.source}: sample period {dt:.9g} s differs from the period {period:.9g} s "
                f"{fmu_path} was trained at; resample the data first"
            )
        outputs = [name for name in slave.names("output") if slave.variables[name].type in ("Real", "Float64")]
        values = np.column_stack([measurement[name] for name in inputs])
        result = np.empty((len(measurement), len(outputs)))
        t0 = float(measurement.time[0])
        slave.enter_initialization(t0)
        parameters = settings.parameters()
        if parameters:
            slave.set_real(list(parameters), list(parameters.values()))
        io = slave.real_io(inputs, outputs)
        io.set(values[0])
        slave.exit_initialization()
        result[0] = io.get()
        for k in range(1, len(measurement)):
            io.set(values[k])
            slave.do_step(t0 + (k - 1) * dt, dt)
            result[k] = io.get()
        units = {name: slave.unit(name) for name in outputs}
    return Measurement(
        time=measurement.time.copy(),
        channels={name: result[:, i] for i, name in enumerate(outputs)},
        units=units,
        source=f"{fmu_path} replayed on {measurement.source}",
    )
