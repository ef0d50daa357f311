"""The pythonfmu backend's FMI 3.0 FMUs (pythonfmu3), run in fmpy and checked against onnxruntime and against the
model description the native backend renders for the same graph."""

from __future__ import annotations

import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import onnx
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu
from onnx import TensorProto, helper

from nnfmu.component import Component, Port
from nnfmu.fmu.model_description import (FmuIdentity, ModelDescriptionView, render_model_description,
                                         tensor_dependencies)
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.pythonfmu import PythonFmuBuildError, build_pythonfmu
from nnfmu.fmu.pythonfmu.fmi3_slave import NnfmuSlave3
from nnfmu.fmu.pythonfmu.model_description_fix import DescriptionFix, fix_model_description
from nnfmu.fmu.pythonfmu.runtimes import runtime
from nnfmu.fmu.variables import fmu_variables
from native_fmu_helpers import hostile_graph
from pythonfmu_helpers import T, VMAX, Reference, build, delay_damper_graph, unzip

VR_VELOCITY, VR_FORCE, VR_EXTRAPOLATING, VR_CUTOFF, VR_GAIN, VR_TIME = range(6)
FMI3_WARNING, FMI3_DISCARD, FMI3_ERROR = 1, 2, 3


class Instance:
    """An fmpy FMU3Slave with a log recorder, initialised with the given parameters."""

    def __init__(self, fmu: Path, name: str, cutoff: float = 0.0, gain: float = 1.0, velocity: float = 0.0,
                 start: float = 0.0, logging_on: bool = True):
        md = read_model_description(str(fmu))
        self.log: list[tuple[int, str, str]] = []
        self.fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzip(fmu),
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(loggingOn=logging_on, logMessage=self._record)
        self.initialise(cutoff, gain, velocity, start)

    def _record(self, env, status, category, message) -> None:
        self.log.append((status, category.decode("utf-8"), message.decode("utf-8")))

    def messages(self, status: int) -> list[str]:
        return [m for s, _, m in self.log if s == status]

    def initialise(self, cutoff: float, gain: float, velocity: float, start: float = 0.0) -> None:
        self.fmu.enterInitializationMode(startTime=start)
        self.fmu.setFloat64([VR_CUTOFF, VR_GAIN, VR_VELOCITY], [cutoff, gain, velocity])
        self.fmu.exitInitializationMode()

    def step(self, t: float, h: float, velocity: float) -> float:
        self.fmu.setFloat64([VR_VELOCITY], [velocity])
        self.fmu.doStep(t, h)
        return self.fmu.getFloat64([VR_FORCE])[0]

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture(scope="module")
def damper(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    return build(tmp_path_factory.mktemp("damper3"), delay_damper_graph(seed=0), "damper", fmi_version=3)


def view_of(onnx_path: Path, fmi_version: int, component: Component | None = None) -> ModelDescriptionView:
    """What the builder describes for the graph at `onnx_path` (described by `component`, default its own)."""
    model = onnx.load(str(onnx_path))
    component = component or Component.from_onnx(model)
    identity = FmuIdentity(component.name, component.name, "{00000000-0000-0000-0000-000000000000}", fmi_version)
    return ModelDescriptionView(identity, component, fmu_variables(component), tensor_dependencies(model),
                                source_files=["graph.c"])  # FMI 2 lists the C sources; any name will do here


def native_description(onnx_path: Path, folder: Path, fmi_version: int = 3) -> Path:
    """The modelDescription.xml the native backend renders for `fmi_version` from the same graph, in `folder`."""
    folder.mkdir()
    (folder / "modelDescription.xml").write_text(render_model_description(view_of(onnx_path, fmi_version)),
                                                 encoding="utf-8")
    return folder


def test_model_description_validates_and_matches_the_native_backend(damper, tmp_path):
    onnx_path, fmu = damper
    assert validate_fmu(str(fmu)) == []
    ours, native = (read_model_description(str(p)) for p in (fmu, native_description(onnx_path, tmp_path / "n")))
    assert ours.fmiVersion == "3.0"

    def variables(md):
        return [(v.name, v.valueReference, v.type, v.causality, v.variability, v.initial, v.unit,
                 None if v.start is None else float(v.start), v.min) for v in md.modelVariables]

    assert variables(ours) == variables(native)
    assert [(v.name, v.valueReference) for v in ours.modelVariables][:2] == [("time", VR_TIME), ("velocity", 0)]
    assert [u.name for u in ours.unitDefinitions] == [u.name for u in native.unitDefinitions]

    def structure(unknowns):
        return [(u.variable.name, [d.name for d in u.dependencies]) for u in unknowns]

    assert structure(ours.outputs) == structure(native.outputs) == [("force", []), ("extrapolating", [])]
    assert structure(ours.initialUnknowns) == structure(native.initialUnknowns)
    assert structure(ours.initialUnknowns) == [("force", ["velocity", "output_gain"]),
                                               ("extrapolating", ["velocity"])]
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


@pytest.mark.parametrize("fmi_version", [2, 3])
def test_hostile_names_validate_and_give_the_native_variables(tmp_path, fmi_version):
    onnx_path, fmu = build(tmp_path, hostile_graph(), "hostile", fmi_version)
    assert validate_fmu(str(fmu)) == []
    ours, native = (read_model_description(str(p)) for p in (fmu, native_description(onnx_path, tmp_path / "n",
                                                                                       fmi_version)))
    assert [(v.name, v.valueReference, v.causality, v.unit, v.description) for v in ours.modelVariables] == [
        (v.name, v.valueReference, v.causality, v.unit, v.description) for v in native.modelVariables]


@pytest.mark.parametrize("h_over_t", [1.0, 2.5])
def test_matches_onnxruntime_over_10000_steps_across_a_serialised_state_rollback(damper, h_over_t):
    onnx_path, fmu = damper
    h = h_over_t * T
    rng = np.random.default_rng(1)
    velocity = rng.uniform(-0.9 * VMAX, 0.9 * VMAX, 10_001)
    detour = rng.uniform(-0.9 * VMAX, 0.9 * VMAX, 100)
    inst, ref = Instance(fmu, "a", velocity=velocity[0]), Reference(onnx_path, velocity=velocity[0])
    assert inst.fmu.getFloat64([VR_FORCE])[0] == pytest.approx(ref.y, rel=1e-12, abs=1e-12)
    got, want = [], []
    for k in range(1, len(velocity)):
        t = (k - 1) * h
        if k == 5000:  # save (through serialisation), wander off, roll back
            saved = inst.fmu.deserializeFMUState(inst.fmu.serializeFMUState(inst.fmu.getFMUState()))
            detoured = [inst.step(t + j * h, h, v) for j, v in enumerate(detour)]
            inst.fmu.setFMUState(saved)
            inst.fmu.freeFMUState(saved)
            assert np.ptp(detoured) > 0
            assert inst.fmu.getFloat64([VR_TIME]) == [pytest.approx(t, rel=1e-15)]
        got.append(inst.step(t, h, velocity[k]))
        want.append(ref.step(t, h, velocity[k]))
    inst.close()
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    assert np.std(want) > 1.0  # the comparison is not between two constants
    assert ref.k == round(10_000 * h_over_t)


def test_a_serialised_state_continues_in_another_instance(damper):
    onnx_path, fmu = damper
    velocity = np.random.default_rng(8).uniform(-0.9 * VMAX, 0.9 * VMAX, 60)
    a, b = Instance(fmu, "a", cutoff=80.0, gain=0.5), Instance(fmu, "b")
    for k, v in enumerate(velocity[:30]):
        a.step(k * T, T, v)
    state = a.fmu.getFMUState()
    data = a.fmu.serializeFMUState(state)
    a.fmu.freeFMUState(state)
    moved = b.fmu.deserializeFMUState(data)
    b.fmu.setFMUState(moved)
    b.fmu.freeFMUState(moved)
    assert b.fmu.getFloat64([VR_CUTOFF, VR_GAIN]) == [80.0, 0.5]
    for k, v in enumerate(velocity[30:], start=30):
        assert b.step(k * T, T, v) == a.step(k * T, T, v)  # bit-identical continuation
    assert a.fmu.getFloat64([VR_FORCE]) != [0.0]
    a.close()
    b.close()


@pytest.mark.parametrize("h_over_t", [2.5, 0.4])
def test_communication_step_other_than_the_sample_period_with_filter_and_gain(damper, h_over_t):
    onnx_path, fmu = damper
    h, n = h_over_t * T, 2000
    velocity = np.random.default_rng(2).uniform(-0.9 * VMAX, 0.9 * VMAX, n)
    inst = Instance(fmu, "b", cutoff=50.0, gain=1.5, velocity=velocity[0])
    ref = Reference(onnx_path, cutoff=50.0, gain=1.5, velocity=velocity[0])
    got = [inst.step(j * h, h, v) for j, v in enumerate(velocity)]
    want = [ref.step(j * h, h, v) for j, v in enumerate(velocity)]
    assert inst.fmu.doStep(n * h, h) == (False, False, False, pytest.approx((n + 1) * h, rel=1e-15))
    inst.close()
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    assert ref.k == int(round(n * h_over_t))  # every sample up to the end was evaluated


def test_samples_count_from_the_first_communication_point_and_a_gap_is_refused(damper):
    onnx_path, fmu = damper
    start, h = 0.25, 2.5 * T
    velocity = np.random.default_rng(6).uniform(-0.9 * VMAX, 0.9 * VMAX, 300)
    inst, ref = Instance(fmu, "late", velocity=velocity[0], start=start), Reference(onnx_path, velocity=velocity[0])
    got = [inst.step(start + j * h, h, v) for j, v in enumerate(velocity)]
    np.testing.assert_allclose(got, [ref.step(j * h, h, v) for j, v in enumerate(velocity)], rtol=1e-12, atol=1e-12)
    assert inst.fmu.getFloat64([VR_TIME]) == [pytest.approx(start + 300 * h, rel=1e-15)]
    with pytest.raises(FMICallException) as gap:
        inst.fmu.doStep(start + 400 * h, h)
    assert gap.value.status == FMI3_DISCARD
    assert any("last communication point" in m for m in inst.messages(FMI3_ERROR))
    inst.close()


def test_instances_are_independent_reset_clears_state_and_fmus_do_not_share_modules(damper, tmp_path):
    onnx_path, fmu = damper
    a, b = Instance(fmu, "a"), Instance(fmu, "b")
    first = [a.step(k * T, T, 0.5) for k in range(5)]
    assert b.step(0.0, T, -0.5) == pytest.approx(Reference(onnx_path).step(0.0, T, -0.5), rel=1e-12, abs=1e-12)
    a.fmu.reset()
    a.initialise(cutoff=0.0, gain=1.0, velocity=0.0)
    assert [a.step(k * T, T, 0.5) for k in range(5)] == first

    other_onnx, other = build(tmp_path, delay_damper_graph(seed=3), "other", fmi_version=3)
    c, ref = Instance(other, "c"), Reference(other_onnx)
    modules = [zipfile.ZipFile(f).read("resources/slavemodule.txt") for f in (fmu, other)]
    assert modules[0] != modules[1]  # same component name, different graphs: different module names
    for k, v in enumerate(np.linspace(-0.5, 0.5, 50)):
        assert c.step(k * T, T, v) == pytest.approx(ref.step(k * T, T, v), rel=1e-12, abs=1e-12)
        assert a.step((k + 5) * T, T, v) != c.fmu.getFloat64([VR_FORCE])[0]
    for inst in (a, b, c):
        inst.close()


def test_fmi2_and_fmi3_fmus_of_one_graph_run_side_by_side(damper, tmp_path):
    onnx_path, fmu3 = damper
    fmu2 = build_pythonfmu(onnx_path, BuildOptions(out=tmp_path / "damper2.fmu", backend="pythonfmu"))
    md2 = read_model_description(str(fmu2))
    two = FMU2Slave(guid=md2.guid, unzipDirectory=unzip(fmu2), modelIdentifier="damper", instanceName="two")
    two.instantiate()
    two.setupExperiment(startTime=0.0)
    two.enterInitializationMode()
    two.setReal([VR_CUTOFF], [30.0])
    two.exitInitializationMode()
    three = Instance(fmu3, "three", cutoff=30.0)
    assert md2.guid != read_model_description(str(fmu3)).guid
    for k, v in enumerate(np.random.default_rng(9).uniform(-0.9, 0.9, 100)):
        two.setReal([VR_VELOCITY], [v])
        two.doStep(k * T, T)
        assert three.step(k * T, T, v) == two.getReal([VR_FORCE])[0]
    two.terminate()
    two.freeInstance()
    three.close()


def test_extrapolating_flag_and_one_warning_per_excursion_while_logging_is_on(damper):
    _, fmu = damper
    inst, quiet = Instance(fmu, "env"), Instance(fmu, "quiet", logging_on=False)
    flags = []
    for k, v in enumerate([0.5, 1.5, 2.0, 1.2, 0.3, -3.0, 0.0]):
        inst.step(k * T, T, v)
        quiet.step(k * T, T, v)
        flags.append(inst.fmu.getBoolean([VR_EXTRAPOLATING])[0])
        assert quiet.fmu.getBoolean([VR_EXTRAPOLATING])[0] == flags[-1]
    quiet.fmu.setFloat64([VR_VELOCITY], [math.nan])  # errors are reported even with logging off
    inst.close()
    quiet.close()
    assert flags == [False, True, True, True, False, True, False]
    assert [s for s, _, _ in quiet.log] == [FMI3_ERROR]
    warnings = [(c, m) for s, c, m in inst.log if s == FMI3_WARNING]
    assert len(warnings) == 2 and all(c == "logStatusWarning" for c, _ in warnings)
    assert "velocity" in warnings[0][1] and "1.5" in warnings[0][1] and "-3.0" in warnings[1][1]


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_input_is_refused_with_an_error_status_and_a_logged_message(damper, bad):
    onnx_path, fmu = damper
    inst, ref = Instance(fmu, "nan"), Reference(onnx_path)
    assert inst.step(0.0, T, 0.2) == pytest.approx(ref.step(0.0, T, 0.2), rel=1e-12, abs=1e-12)
    inst.fmu.setFloat64([VR_VELOCITY], [bad])
    with pytest.raises(FMICallException) as refused:
        inst.fmu.doStep(T, T)
    assert refused.value.status == FMI3_DISCARD
    assert any("velocity" in m and repr(bad) in m for m in inst.messages(FMI3_ERROR))
    assert inst.fmu.getFloat64([VR_VELOCITY]) == [0.2]  # the refused value never reached the graph
    assert inst.step(T, T, 0.1) == pytest.approx(ref.step(T, T, 0.1), rel=1e-12, abs=1e-12)
    inst.close()


def test_fixed_parameters_and_outputs_cannot_be_set_after_initialisation(damper):
    onnx_path, fmu = damper
    inst, ref = Instance(fmu, "fixed", gain=2.0), Reference(onnx_path, gain=2.0)
    inst.fmu.setFloat64([VR_GAIN, VR_FORCE], [5.0, 1.0])
    inst.fmu.setBoolean([VR_EXTRAPOLATING], [True])
    errors = inst.messages(FMI3_ERROR)
    assert len(errors) == 3 and "'output_gain' is fixed" in errors[0] and "keeps 2.0" in errors[0]
    assert "value reference 1 is not a settable Real" in errors[1] and "reference 2" in errors[2]
    assert inst.fmu.getFloat64([VR_GAIN]) == [2.0]
    assert inst.step(0.0, T, 0.3) == pytest.approx(ref.step(0.0, T, 0.3), rel=1e-12, abs=1e-12)
    inst.close()


def test_graph_without_component_gets_a_generic_description_evaluated_each_step(tmp_path, monkeypatch):
    node = helper.make_node("Tanh", ["x"], ["y"])
    graph = helper.make_graph([node], "plain", [helper.make_tensor_value_info("x", TensorProto.DOUBLE, [2])],
                              [helper.make_tensor_value_info("y", TensorProto.DOUBLE, [2])])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=9)
    onnx.save(model, str(tmp_path / "plain.onnx"))
    monkeypatch.chdir(tmp_path)
    fmu = build_pythonfmu(tmp_path / "plain.onnx", BuildOptions(backend="pythonfmu", fmi_version=3))
    assert fmu == Path("exported/plain.fmu")
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.coSimulation.modelIdentifier == "plain" and md.defaultExperiment.stepSize is None
    assert [(v.name, v.valueReference) for v in md.modelVariables][:5] == [
        ("time", 7), ("x[0]", 0), ("x[1]", 1), ("y[0]", 2), ("y[1]", 3)]
    inst = FMU3Slave(guid=md.guid, unzipDirectory=unzip(fmu), modelIdentifier="plain", instanceName="p")
    inst.instantiate()
    inst.enterInitializationMode(startTime=0.0)
    inst.setFloat64([5], [5.0])  # filter_cutoff [Hz]; without a sample period the filter runs at the step size
    inst.exitInitializationMode()
    t, y = 0.0, np.tanh([0.0, 0.0])
    for h, x in [(0.01, [0.3, -0.1]), (0.5, [-2.0, 0.4]), (0.001, [1.0, 1.0]), (0.02, [0.7, -3.0])]:
        inst.setFloat64([0, 1], x)
        inst.doStep(t, h)
        t += h
        y = y + (1.0 - math.exp(-2.0 * math.pi * 5.0 * h)) * (np.tanh(x) - y)
        np.testing.assert_allclose(inst.getFloat64([2, 3]), y, rtol=1e-14, atol=1e-15)
    inst.terminate()
    inst.freeInstance()


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
    again = build_pythonfmu(onnx_path, BuildOptions(out=tmp_path / "again.fmu", backend="pythonfmu", fmi_version=3))
    assert again.read_bytes() == fmu.read_bytes()


def test_a_missing_pythonfmu3_is_reported_with_the_package_to_install(damper, tmp_path, monkeypatch):
    onnx_path, _ = damper
    monkeypatch.setitem(sys.modules, "pythonfmu3", None)  # `import pythonfmu3` now raises ImportError
    with pytest.raises(PythonFmuBuildError, match=r"pythonfmu3==0\.3\.4"):
        build_pythonfmu(onnx_path, BuildOptions(out=tmp_path / "x.fmu", backend="pythonfmu", fmi_version=3))
    assert not (tmp_path / "x.fmu").exists()
