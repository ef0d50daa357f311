"""What a user's master gets from an FMU: a replay with fmpy alone (no nnfmu code) at the FMU's default parameters.

The inputs of sample k are set before the step that ends at t_k, so the output read there is the model's response
to them (the alignment of the network's training data); sample 0 is evaluated when initialisation ends.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave


def plain_replay(fmu_path: Path, inputs: dict[str, np.ndarray], step: float, output: str) -> np.ndarray:
    """`output` of the FMI 2 FMU at every sample of `inputs` (arrays by FMU input name), parameters untouched."""
    description = read_model_description(str(fmu_path))
    refs = {v.name: v.valueReference for v in description.modelVariables}
    names = [v.name for v in description.modelVariables if v.causality == "input"]
    columns = np.column_stack([inputs[name] for name in names])
    folder = extract(str(fmu_path))
    fmu = FMU2Slave(
        guid=description.guid,
        unzipDirectory=folder,
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="plain",
    )
    try:
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setReal([refs[n] for n in names], list(columns[0]))
        fmu.exitInitializationMode()
        result = np.empty(len(columns))
        result[0] = fmu.getReal([refs[output]])[0]
        for k in range(1, len(columns)):
            fmu.setReal([refs[n] for n in names], list(columns[k]))
            fmu.doStep(currentCommunicationPoint=(k - 1) * step, communicationStepSize=step)
            result[k] = fmu.getReal([refs[output]])[0]
        fmu.terminate()
    finally:
        fmu.freeInstance()
        shutil.rmtree(folder, ignore_errors=True)
    return result
