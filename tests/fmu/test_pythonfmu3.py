"""The pythonfmu backend's FMI 3.0 FMUs (pythonfmu3): what is particular to FMI 3, checked against the model description
the native backend renders for the same graph. What the backend does for both FMI versions is tested in
test_pythonfmu.py, the FMU semantics of every backend in test_contract.py."""

from __future__ import annotations

import sys
import zipfile
from pathlib import Path

import numpy as np
import onnx
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from pythonfmu_helpers import ERROR, Instance, Reference, T, native_description, unzip, view_of

from nnfmu.component import Component, Port
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.pythonfmu import PythonFmuBuildError
from nnfmu.fmu.pythonfmu.fmi3_slave import NnfmuSlave3
from nnfmu.fmu.pythonfmu.model_description_fix import DescriptionFix, fix_model_description
from nnfmu.fmu.pythonfmu.runtimes import runtime

VR_FORCE, VR_EXTRAPOLATING, VR_GAIN, VR_TIME = 1, 2, 4, 5


@pytest.fixture
def damper(pythonfmu_dampers) -> tuple[Path, Path]:
    return pythonfmu_dampers[3]


def test_model_description_validates_and_matches_the_native_backend(damper, tmp_path):
    onnx_path, fmu = damper
    assert validate_fmu(str(fmu)) == []
    ours, native = (read_model_description(str(p)) for p in (fmu, native_description(onnx_path, tmp_path / "n")))
    assert ours.fmiVersion == "3.0"

    def variables(md):
        return [
            (
                v.name,
                v.valueReference,
                v.type,
                v.causality,
                v.variability,
                v.initial,
                v.unit,
                None if v.start is None else float(v.start),
                v.min,
            )
            for v in md.modelVariables
        ]

    assert variables(ours) == variables(native)
    assert [(v.name, v.valueReference) for v in ours.modelVariables][:2] == [("time", VR_TIME), ("velocity", 0)]
    assert [u.name for u in ours.unitDefinitions] == [u.name for u in native.unitDefinitions]

    def structure(unknowns):
        return [(u.variable.name, [d.name for d in u.dependencies]) for u in unknowns]

    assert structure(ours.outputs) == structure(native.outputs) == [("force", []), ("extrapolating", [])]
    assert structure(ours.initialUnknowns) == structure(native.initialUnknowns)
    assert structure(ours.initialUnknowns) == [("force", ["velocity", "output_gain"]), ("extrapolating", ["velocity"])]
    cs = ours.coSimulation
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate and cs.canHandleVariableCommunicationStepSize
    assert cs.needsExecutionTool and float(ours.defaultExperiment.stepSize) == T
    assert "onnxruntime" in ours.description and "PythonFMU3 0.3.4" in ours.generationTool
    assert zipfile.ZipFile(fmu).getinfo("binaries/x86_64-linux/damper.so").file_size > 0


def test_fix_writes_the_flags_pythonfmu3_derives_from_another_option_and_checks_the_table(damper):
    onnx_path, fmu = damper
    slave = NnfmuSlave3(instance_name="probe", resources=str(Path(unzip(fmu)) / "resources"))
    flags = dict(runtime(3).capabilities, canSerializeFMUState=False)
    raw = slave.to_xml(flags)
    assert raw.find("CoSimulation").get("canHandleVariableCommunicationStepSize") == "false"  # the pythonfmu3 pitfall
    fixed = fix_model_description(raw, DescriptionFix(view_of(onnx_path, 3), "test", "test", flags))
    assert fixed.find("CoSimulation").get("canHandleVariableCommunicationStepSize") == "true"
    assert fixed.find("CoSimulation").get("canSerializeFMUState") == "false"

    component = Component.from_onnx(onnx.load(str(onnx_path)))
    component.outputs[0] = Port("torque", "N.m")
    with pytest.raises(PythonFmuBuildError, match="torque"):
        fix_model_description(slave.to_xml(flags), DescriptionFix(view_of(onnx_path, 3, component), "t", "t", flags))


def test_fmi2_and_fmi3_fmus_of_one_graph_run_side_by_side(pythonfmu_dampers):
    (_, fmu2), (_, fmu3) = pythonfmu_dampers[2], pythonfmu_dampers[3]
    two, three = Instance(fmu2, "two", cutoff=30.0), Instance(fmu3, "three", cutoff=30.0)
    assert (two.fmi_version, three.fmi_version) == (2, 3)
    assert two.description.guid != three.description.guid
    for k, v in enumerate(np.random.default_rng(9).uniform(-0.9, 0.9, 100)):
        assert three.step(k * T, T, v) == two.step(k * T, T, v)
    two.close()
    three.close()


def test_fixed_parameters_and_outputs_cannot_be_set_after_initialisation(damper):
    onnx_path, fmu = damper
    inst, ref = Instance(fmu, "fixed", gain=2.0), Reference(onnx_path, gain=2.0)
    inst.fmu.setFloat64([VR_GAIN, VR_FORCE], [5.0, 1.0])
    inst.fmu.setBoolean([VR_EXTRAPOLATING], [True])
    errors = inst.logged(ERROR)
    assert len(errors) == 3 and "'output_gain' is fixed" in errors[0] and "keeps 2.0" in errors[0]
    assert "value reference 1 is not a settable Real" in errors[1] and "reference 2" in errors[2]
    assert inst.fmu.getFloat64([VR_GAIN]) == [2.0]
    assert inst.step(0.0, T, 0.3) == pytest.approx(ref.step(0.0, T, 0.3), rel=1e-12, abs=1e-12)
    inst.close()


def test_a_missing_pythonfmu3_is_reported_with_the_package_to_install(damper, tmp_path, monkeypatch):
    onnx_path, _ = damper
    monkeypatch.setitem(sys.modules, "pythonfmu3", None)  # `import pythonfmu3` now raises ImportError
    with pytest.raises(PythonFmuBuildError, match=r"pythonfmu3==0\.3\.4"):
        build_fmu(onnx_path, BuildOptions(out=tmp_path / "x.fmu", backend="pythonfmu", fmi_version=3))
    assert not (tmp_path / "x.fmu").exists()
