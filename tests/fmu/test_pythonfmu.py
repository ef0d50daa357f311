"""What only the pythonfmu backend has, run in fmpy against onnxruntime on the same step graph: per-FMU slave modules,
JSON FMU states, a slave that needs no nnfmu, the description fix (each for FMI 2 and FMI 3), then what is particular
to FMI 2 (pythonfmu). The FMU semantics both backends share are the contract suite's (test_contract.py); FMI 3's own
tests are in test_pythonfmu3.py."""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import onnx
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from native_fmu_helpers import hostile_graph
from pythonfmu_helpers import (
    DISCARD,
    ERROR,
    Instance,
    Reference,
    T,
    build,
    delay_damper_graph,
    native_description,
    unzip,
)

from nnfmu.component import Component, Port
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.model_description import FmuIdentity, ModelDescriptionView, tensor_dependencies
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.pythonfmu import PythonFmuBuildError
from nnfmu.fmu.pythonfmu.fmi2_slave import NnfmuSlave
from nnfmu.fmu.pythonfmu.model_description_fix import DescriptionFix, fix_model_description
from nnfmu.fmu.pythonfmu.runtimes import runtime
from nnfmu.fmu.variables import fmu_variables


@pytest.fixture(params=[2, 3], ids=["fmi2", "fmi3"])
def damper(request: pytest.FixtureRequest, pythonfmu_dampers) -> tuple[Path, Path]:
    """The damper's (onnx, fmu) for each FMI version in turn."""
    return pythonfmu_dampers[request.param]


@pytest.fixture
def damper2(pythonfmu_dampers) -> tuple[Path, Path]:
    return pythonfmu_dampers[2]


def description_fix(onnx_path: Path, component: Component | None = None) -> DescriptionFix:
    """The fix the builder applies, for the graph at `onnx_path` described by `component` (default: its own)."""
    model = onnx.load(str(onnx_path))
    component = component or Component.from_onnx(model)
    identity = FmuIdentity(component.name, component.name, "{00000000-0000-0000-0000-000000000000}", 2)
    view = ModelDescriptionView(identity, component, fmu_variables(component), tensor_dependencies(model))
    return DescriptionFix(view, "test damper", "test", runtime(2).capabilities)


# ----- both FMI versions -------------------------------------------------------------------------------------------


def test_two_different_fmus_with_the_same_name_in_one_process(damper, tmp_path):
    onnx_path, fmu = damper
    version = read_model_description(str(fmu)).fmiVersion[0]
    other_onnx, other = build(tmp_path, delay_damper_graph(seed=3), "other", fmi_version=int(version))
    instances = [Instance(fmu, "a"), Instance(other, "c")]
    refs = [Reference(onnx_path), Reference(other_onnx)]
    modules = [zipfile.ZipFile(f).read("resources/slavemodule.txt") for f in (fmu, other)]
    assert modules[0] != modules[1]  # Python caches modules by name: each FMU ships the slave under its own
    for k, v in enumerate(np.random.default_rng(5).uniform(-0.5, 0.5, 200)):
        for inst, ref in zip(instances, refs):
            assert inst.step(k * T, T, v) == pytest.approx(ref.step(k * T, T, v), rel=1e-12, abs=1e-12)
        assert instances[0].force() != instances[1].force()
    for inst in instances:
        inst.close()


@pytest.mark.parametrize(
    ("field", "forged", "named"),
    [
        ("inputs", [0.1, 0.2, 0.3], "'inputs' holds 3 values, expected 1"),
        ("inputs", ["fast"], "'inputs' holds 'fast'"),
        ("time", "soon", "'time' is 'soon'"),
        ("sample", -7, "'sample' is -7"),
        ("parameters", {"output_gain": 1.0}, "'parameters' names"),
        ("refused", None, "'refused' is missing"),
        ("bytes", b"garbage", "its bytes are no JSON object"),
        ("bytes", b"[1, 2]", "its bytes are no JSON object (a JSON list)"),
    ],
)
def test_a_forged_or_garbage_state_is_refused_naming_the_field_and_the_instance_recovers(damper, field, forged, named):
    """pythonfmu makes any exception in these calls fatal (and then corrupts its heap freeing the instance), so the
    state is refused in the FMU: error logged, own state kept, steps refused until a valid state is set."""
    onnx_path, fmu = damper
    inst, ref = Instance(fmu, "forged"), Reference(onnx_path)
    assert inst.step(0.0, T, 0.1) == pytest.approx(ref.step(0.0, T, 0.1), rel=1e-12, abs=1e-12)
    two = inst.fmi_version == 2
    good = inst.fmu.getFMUstate() if two else inst.fmu.getFMUState()
    data = bytes(inst.fmu.serializeFMUstate(good) if two else inst.fmu.serializeFMUState(good))
    if field != "bytes":
        state = json.loads(data)
        if forged is None:
            del state[field]
        else:
            state[field] = forged
        data = json.dumps(state).encode()
    else:
        data = forged
    bad = inst.fmu.deSerializeFMUstate(data) if two else inst.fmu.deserializeFMUState(data)
    inst.set_state(bad)
    assert any(named in m for m in inst.logged(ERROR)), inst.messages
    with pytest.raises(FMICallException) as refused:
        inst.do_step(T, T)
    assert refused.value.status == DISCARD
    assert any("doStep" in m and named in m for m in inst.logged(ERROR)), inst.messages
    inst.set_state(good)  # a valid state ends the refusal
    assert inst.step(T, T, 0.3) == pytest.approx(ref.step(T, T, 0.3), rel=1e-12, abs=1e-12)
    inst.free_state(bad)
    inst.free_state(good)
    inst.close()


@pytest.mark.parametrize("fmi_version", [2, 3])
def test_hostile_names_validate_and_give_the_native_variables(tmp_path, fmi_version):
    onnx_path, fmu = build(tmp_path, hostile_graph(), "hostile", fmi_version)
    assert validate_fmu(str(fmu)) == []
    ours, native = (
        read_model_description(str(p)) for p in (fmu, native_description(onnx_path, tmp_path / "n", fmi_version))
    )
    assert [(v.name, v.valueReference, v.causality, v.unit, v.description) for v in ours.modelVariables] == [
        (v.name, v.valueReference, v.causality, v.unit, v.description) for v in native.modelVariables
    ]


def test_the_fmu_runs_in_a_python_without_nnfmu(damper):
    onnx_path, fmu = damper
    script = (
        "import sys; sys.modules['nnfmu'] = None\n"  # any `import nnfmu` now fails
        "from fmpy import simulate_fmu\n"
        f"r = simulate_fmu({str(fmu)!r}, stop_time=0.01, output_interval={T!r},\n"
        "                  start_values={'filter_cutoff': 0.0, 'velocity': 0.4})\n"
        "print(repr(float(r['force'][-1])))\n"
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    ref = Reference(onnx_path, velocity=0.4)
    want = [ref.step(k * T, T, 0.4) for k in range(10)][-1]
    assert want != ref.gain * Reference(onnx_path).y  # the delay line has moved away from rest
    assert float(run.stdout.strip().splitlines()[-1]) == pytest.approx(want, rel=1e-12, abs=1e-12)


def test_the_same_graph_builds_the_same_fmu_bytes(damper, tmp_path):
    onnx_path, fmu = damper
    version = int(read_model_description(str(fmu)).fmiVersion[0])
    again = build_fmu(onnx_path, BuildOptions(out=tmp_path / "again.fmu", backend="pythonfmu", fmi_version=version))
    assert again.read_bytes() == fmu.read_bytes()


# ----- FMI 2 only --------------------------------------------------------------------------------------------------
def test_model_description_validates_and_matches_the_variable_table(damper2):
    onnx_path, fmu = damper2
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    expected = fmu_variables(Component.from_onnx(onnx.load(str(onnx_path)))).all
    got = [(v.name, v.valueReference, v.causality, v.type, v.unit or "") for v in md.modelVariables]
    assert got == [(v.name, v.value_reference, v.causality, v.type, v.unit) for v in expected]
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert float(md.defaultExperiment.stepSize) == T
    assert "onnxruntime" in md.description


def test_fix_adds_the_initial_unknowns_that_pythonfmu_leaves_out(damper2):
    onnx_path, fmu = damper2
    extracted = Path(unzip(fmu))
    raw = NnfmuSlave(instance_name="probe", resources=str(extracted / "resources")).to_xml()
    (extracted / "modelDescription.xml").write_bytes(ET.tostring(raw, encoding="UTF-8", xml_declaration=True))
    assert any("InitialUnknowns" in problem for problem in validate_fmu(str(extracted)))  # the pythonfmu pitfall

    fixed = fix_model_description(raw, description_fix(onnx_path))
    (extracted / "modelDescription.xml").write_bytes(ET.tostring(fixed, encoding="UTF-8", xml_declaration=True))
    assert validate_fmu(str(extracted)) == []
    unknowns = [(u.get("index"), u.get("dependencies")) for u in fixed.findall("ModelStructure/InitialUnknowns/")]
    assert unknowns == [("2", "1 5"), ("3", "1")]  # force <- velocity, output_gain; extrapolating <- velocity
    assert fixed.find("ModelVariables/ScalarVariable[@name='velocity']/Real").get("unit") == "m/s"


def test_fix_refuses_a_description_that_disagrees_with_the_variable_table(damper2):
    onnx_path, fmu = damper2
    slave = NnfmuSlave(instance_name="probe", resources=str(Path(unzip(fmu)) / "resources"))
    component = Component.from_onnx(onnx.load(str(onnx_path)))
    component.outputs[0] = Port("torque", "N.m")
    with pytest.raises(PythonFmuBuildError, match="torque"):
        fix_model_description(slave.to_xml(), description_fix(onnx_path, component))


def test_fixed_parameters_are_refused_once_initialisation_ends(damper2):
    onnx_path, fmu = damper2
    inst, ref = Instance(fmu, "fixed", gain=2.0), Reference(onnx_path, gain=2.0)
    inst.set_real(["output_gain", "filter_cutoff"], [5.0, 10.0])
    errors = inst.logged(ERROR)
    assert len(errors) == 2 and "'output_gain' is fixed" in errors[0] and "keeps 2.0" in errors[0]
    assert list(inst.get_real(["output_gain", "filter_cutoff"])) == [2.0, 0.0]
    assert inst.step(0.0, T, 0.3) == pytest.approx(ref.step(0.0, T, 0.3), rel=1e-12, abs=1e-12)
    inst.close()


def test_a_component_that_does_not_fit_its_graph_is_refused_at_build_time(tmp_path):
    model = delay_damper_graph(seed=7)
    component = Component.from_onnx(model)
    component.inputs[0] = Port("speed", "m/s")
    component.attach_to(model)
    with pytest.raises(PythonFmuBuildError, match="'speed'"):
        build(tmp_path, model, "misfit")
    assert not (tmp_path / "misfit.fmu").exists()


def test_name_option_renames_the_component_and_gives_a_c_model_identifier(damper2, tmp_path):
    onnx_path, _ = damper2
    fmu = build_fmu(onnx_path, BuildOptions(out=tmp_path / "fl.fmu", backend="pythonfmu", name="front-left 1"))
    md = read_model_description(str(fmu))
    assert (md.modelName, md.coSimulation.modelIdentifier) == ("front-left 1", "front_left_1")
    assert zipfile.ZipFile(fmu).getinfo("binaries/linux64/front_left_1.so").file_size > 0
    assert validate_fmu(str(fmu)) == []


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_huge_start_time_steps_as_from_zero(pythonfmu_dampers, open_fmu, fmi):
    """At t_start = 1e300 a step of one sample period does not move the float time at all: the samples are counted
    from the elapsed time (the sum of the steps), as the native FMU counts them, so each step evaluates one sample
    instead of looping for ever."""
    import time

    onnx_path, fmu = pythonfmu_dampers[fmi]
    period = Component.from_onnx(onnx.load(onnx_path)).sample_period
    zero = open_fmu(fmu, "zero")
    inputs = np.random.default_rng(2).uniform(-0.5, 0.5, (40, len(zero.inputs)))
    expected = zero.simulate(inputs, period)
    started = time.perf_counter()
    got = open_fmu(fmu, "huge").simulate(inputs, period, start=1e300)
    assert time.perf_counter() - started < 10
    np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("start", [float("nan"), float("inf")])
def test_a_start_time_that_is_not_finite_is_refused_at_initialisation(pythonfmu_dampers, open_fmu, start):
    """The error is logged when the start time is set; pythonfmu gives initialisation no error status, so every step
    is refused (an error status) instead of running on a clock that cannot advance."""
    slave = open_fmu(pythonfmu_dampers[2][1])
    slave.initialize(np.zeros(len(slave.inputs)), start=start)
    assert any(f"start time {start!r} s is not finite" in message for _, _, message in slave.messages)
    with pytest.raises(FMICallException):
        slave.do_step(0.0, 1e-3)
