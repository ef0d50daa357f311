"""A damper-semiactive network as an FMU: the command is an input port with its unit, and fmpy replays the FMU as
onnxruntime evaluates the step graph (and as the trained model predicts), both FMI versions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest
from fmpy import read_model_description
from native_fmu_helpers import Reference

from nnfmu.data import load_measurement
from nnfmu.data.rigs import RigOptions, write_rig
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.workflows.train import TrainRequest, train_from_file

STEPS = 1500


@pytest.fixture(scope="module")
def semiactive(tmp_path_factory) -> dict[str, tuple[Path, object, object]]:
    """Tiny damper-semiactive networks on short MR and CDC records: {type: (onnx, outcome, record)}."""
    folder = tmp_path_factory.mktemp("semiactive_fmu")
    out = {}
    for damper_type in ("mr", "cdc"):
        data, _ = write_rig(
            "damper",
            folder / f"{damper_type}.csv",
            RigOptions(damper_type=damper_type, duration=4.0, excitation="random", seed=4),
        )
        request = TrainRequest("damper-semiactive", hidden=(3,), restarts=1, max_epochs=3)
        outcome = train_from_file(data, request, folder / f"{damper_type}.onnx")
        out[damper_type] = (folder / f"{damper_type}.onnx", outcome, load_measurement(data))
    return out


@pytest.mark.parametrize(
    ("damper_type", "channel", "unit", "fmi"),
    [
        ("mr", "voltage", "V", 2),
        ("cdc", "current", "A", 3),
    ],
)
@pytest.mark.slow
def test_the_command_is_an_fmu_input_with_its_unit_and_fmpy_replays_onnxruntime(
    semiactive, open_fmu, tmp_path, damper_type, channel, unit, fmi
):
    onnx_path, outcome, record = semiactive[damper_type]
    fmu = build_fmu(onnx_path, BuildOptions(out=tmp_path / f"{damper_type}.fmu", fmi_version=fmi))
    variables = {v.name: v for v in read_model_description(str(fmu)).modelVariables}
    assert variables[channel].causality == "input" and variables[channel].unit == unit
    assert variables["force"].causality == "output" and variables["force"].unit == "N"

    reference = Reference(onnx.load(str(onnx_path)))
    names = [port.name for port in reference.component.inputs]
    assert set(names) == {"velocity", "displacement", channel}
    inputs = np.column_stack([record[name][:STEPS] for name in names])
    slave = open_fmu(fmu)
    assert slave.inputs == names
    got = slave.simulate(inputs, record.sample_period, parameters={"filter_cutoff": 0.0})
    expected = reference.simulate(inputs, record.sample_period)
    force = slave.outputs.index("force")
    peak = np.max(np.abs(expected[:, force]))
    assert np.max(np.abs(got[:, force] - expected[:, force])) <= 1e-12 * peak
    predicted = outcome.model.predict({name: record[name][:STEPS] for name in names})
    np.testing.assert_allclose(expected[:, force], predicted, rtol=1e-9, atol=1e-9 * peak)
