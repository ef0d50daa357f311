"""What a user's master gets from an FMU: fmpy alone (no nnfmu code) stepping an FMI 2 FMU at its default parameters.

`plain_run` is the hand-written loop the tests and benches share: instantiate, the inputs at t_0 set in
Initialization Mode, then per step the inputs set, doStep, the outputs read. `plain_replay` is a replay on it: the
inputs of sample k are set before the step that ends at t_k, so the output read there is the model's response to
them (the alignment of a network's training data); sample 0 is evaluated when initialisation ends.
"""

from __future__ import annotations

import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave


def port_names(fmu: Path, causality: str) -> list[str]:
    """Names of the variables of `fmu` with `causality` ("input", "output"), in the model description's order."""
    return [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == causality]


def plain_run(
    fmu: Path,
    inputs: Mapping[str, np.ndarray],
    step: float,
    outputs: Sequence[str],
    *,
    at_start: bool = False,
    slopes: bool = False,
    instance: str = "plain",
) -> np.ndarray:
    """`outputs` of the FMI 2 FMU at t_k = k `step`, k = 0..n: (n + 1, len(outputs)). `inputs` holds every FMU input's
    values at t_0..t_n. Those at t_0 are set in Initialization Mode; then each step from t_k sets the inputs at
    t_{k+1} (`at_start`: at t_k, a master's drive sampled at the communication points), with `slopes` also their
    slope (u_{k+1} - u_k) / step as first input derivatives, calls doStep(t_k, step) and reads the outputs. A failed
    doStep raises RuntimeError naming the FMU and t_k."""
    description = read_model_description(str(fmu))
    refs = {v.name: v.valueReference for v in description.modelVariables}
    names = [v.name for v in description.modelVariables if v.causality == "input"]
    u = np.column_stack([inputs[name] for name in names])
    vr_in, vr_out = [refs[name] for name in names], [refs[name] for name in outputs]
    folder = extract(str(fmu))
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=folder,
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName=instance,
    )
    try:
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.setReal(vr_in, list(u[0]))
        slave.exitInitializationMode()
        rows = [slave.getReal(vr_out)]
        for k in range(len(u) - 1):
            slave.setReal(vr_in, list(u[k] if at_start else u[k + 1]))
            if slopes:
                slave.setRealInputDerivatives(vr_in, [1] * len(vr_in), list((u[k + 1] - u[k]) / step))
            try:
                slave.doStep(currentCommunicationPoint=k * step, communicationStepSize=step)
            except FMICallException as error:
                raise RuntimeError(f"{fmu.name}: doStep from t = {k * step:.3f} s failed ({error})") from error
            rows.append(slave.getReal(vr_out))
        slave.terminate()
    finally:
        slave.freeInstance()
        shutil.rmtree(folder, ignore_errors=True)
    return np.array(rows)


def plain_replay(fmu_path: Path, inputs: dict[str, np.ndarray], step: float, output: str) -> np.ndarray:
    """`output` of the FMI 2 FMU at every sample of `inputs` (arrays by FMU input name), parameters untouched."""
    return plain_run(fmu_path, inputs, step, [output])[:, 0]
