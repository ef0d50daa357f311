"""fmpy's validate_fmu finds no problems in native FMUs (FMI 2 and 3), and the model description says what it should."""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile

import onnx
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from native_fmu_helpers import SAMPLE_PERIOD, delay_step_graph, hostile_graph

from nnfmu.component import Component, Port
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions


@pytest.mark.parametrize("fmi", [2, 3])
def test_step_graph_fmu_validates(delay_fmus, fmi):
    assert validate_fmu(str(delay_fmus[fmi])) == []


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_generic_and_hostile_fmus_validate(generic_onnx, tmp_path, fmi):
    hostile = tmp_path / "hostile.onnx"
    onnx.save(hostile_graph(), str(hostile))
    for source in (generic_onnx, hostile):
        path = build_fmu(source, BuildOptions(out=tmp_path / f"{source.stem}{fmi}.fmu", fmi_version=fmi))
        assert validate_fmu(str(path)) == [], source.name


@pytest.mark.parametrize("fmi", [2, 3])
def test_variables_units_and_experiment(delay_fmus, fmi):
    md = read_model_description(str(delay_fmus[fmi]))
    variables = {v.name: v for v in md.modelVariables}
    assert variables["velocity"].causality == "input" and variables["velocity"].unit == "m/s"
    assert variables["force"].causality == "output" and variables["force"].unit == "N"
    assert variables["extrapolating"].type == "Boolean" and variables["extrapolating"].causality == "output"
    assert variables["filter_cutoff"].causality == "parameter" and float(variables["filter_cutoff"].start) == 0.0
    assert variables["filter_cutoff"].unit == "Hz" and float(variables["output_gain"].start) == 1.0
    assert variables["velocity"].description == "piston velocity"
    units = {u.name: u.baseUnit for u in md.unitDefinitions}
    assert sorted(units) == sorted({"m/s", "m", "N", "N.m", "Hz", "1"} | ({"s"} if fmi == 3 else set()))
    assert (units["N"].kg, units["N"].m, units["N"].s) == (1, 1, -2)
    assert (units["N.m"].kg, units["N.m"].m, units["N.m"].s) == (1, 2, -2)
    assert (units["Hz"].s, units["m/s"].m, units["m/s"].s) == (-1, 1, -1)
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert float(md.defaultExperiment.stepSize) == SAMPLE_PERIOD


@pytest.mark.parametrize("fmi", [2, 3])
def test_model_structure(delay_fmus, fmi):
    md = read_model_description(str(delay_fmus[fmi]))
    outputs = {u.variable.name: u for u in md.outputs}
    assert set(outputs) == {"force", "torque", "extrapolating"}
    assert all(u.dependencies == [] for u in outputs.values())  # outputs change only in doStep
    initial = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md.initialUnknowns}
    assert initial == {
        "force": ["displacement", "output_gain", "velocity"],
        "torque": ["displacement", "output_gain", "velocity"],
        "extrapolating": ["displacement", "velocity"],
    }


def test_xml_escapes_hostile_text(tmp_path):
    hostile = tmp_path / "hostile.onnx"
    onnx.save(hostile_graph(), str(hostile))
    path = build_fmu(hostile, BuildOptions(out=tmp_path / "h.fmu", name='a "b" <c> & d'))
    with zipfile.ZipFile(path) as archive:
        text = archive.read("modelDescription.xml").decode()
        config = archive.read("sources/config.h").decode()
    root = ET.fromstring(text)  # well-formed despite quotes, <, &, */ and control characters
    assert root.get("modelName") == 'a "b" <c> & d'
    assert "\x01" not in text and "&lt;c&gt;" in text
    assert "*/ <graph>" not in config and config.count("*/") == config.count("/*")


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_hostile_units_and_descriptions_in_nnfmu_metadata(tmp_path, fmi):
    model = delay_step_graph()
    component = Component.from_onnx(model)
    force = component.outputs[0]
    component.outputs[0] = Port(force.name, 'N"<&*/%s\n', 'desc */ "<&>" %n\x02', force.tensor, force.index)
    component.attach_to(model)
    source = tmp_path / "odd_units.onnx"
    onnx.save(model, str(source))
    path = build_fmu(source, BuildOptions(out=tmp_path / "odd.fmu", fmi_version=fmi))  # compiles with -Werror
    assert validate_fmu(str(path)) == []
    variables = {v.name: v for v in read_model_description(str(path)).modelVariables}
    assert variables["force"].unit.startswith('N"<&*/%s') and "*/" in variables["force"].description
