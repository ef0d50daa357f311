"""The native FMU against an onnxruntime reference of the FMU semantics (docs/architecture.md), both FMI versions."""

from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import numpy as np
import onnx
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime
from onnx import helper

from native_fmu_helpers import SAMPLE_PERIOD, Reference, delay_step_graph, generic_graph, hostile_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.options import BuildOptions

T = SAMPLE_PERIOD
RTOL = 1e-9  # float64 graph: the C and onnxruntime differ by rounding only
ATOL = 1e-12


def random_inputs(n: int, seed: int, inside: bool = True) -> np.ndarray:
    rng = np.random.default_rng(seed)
    scale = 1.0 if inside else 1.5
    return np.column_stack([rng.uniform(-scale, scale, n), rng.uniform(-0.1 * scale, 0.1 * scale, n)])


@pytest.fixture(scope="module")
def reference() -> Reference:
    return Reference(delay_step_graph())


@pytest.mark.parametrize("fmi", [2, 3])
def test_10000_steps_match_onnxruntime_with_the_thesis_filter(delay_fmus, open_fmu, reference, fmi):
    inputs = random_inputs(10_001, seed=fmi)
    got = open_fmu(delay_fmus[fmi]).simulate(inputs, T, parameters={"filter_cutoff": 100.0})
    np.testing.assert_allclose(got, reference.simulate(inputs, T, cutoff=100.0), rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("fmi", [2, 3])
def test_at_default_parameters_the_fmu_is_its_graph(delay_fmus, generic_onnx, open_fmu, reference, tmp_path, fmi):
    """What a plain master gets: no parameter set, every output within 1e-12 of its peak of onnxruntime's graph."""
    def assert_within_1e12_of_peak(got: np.ndarray, expected: np.ndarray) -> None:
        error = np.max(np.abs(got - expected), axis=0) / np.max(np.abs(expected), axis=0)
        assert np.all(error <= 1e-12), error

    inputs = random_inputs(2_001, seed=20 + fmi)
    assert_within_1e12_of_peak(open_fmu(delay_fmus[fmi]).simulate(inputs, T), reference.simulate(inputs, T))
    foreign = build_fmu(generic_onnx, BuildOptions(out=tmp_path / "foreign.fmu", fmi_version=fmi))
    values = np.random.default_rng(fmi).uniform(-1, 1, (1_000, 3))
    assert_within_1e12_of_peak(open_fmu(foreign).simulate(values, 1e-3),
                               Reference(generic_graph()).simulate(values, 1e-3))


@pytest.mark.parametrize("fmi", [2, 3])
def test_build_option_sets_the_filter_start_value(delay_onnx, open_fmu, reference, tmp_path, fmi):
    path = build_fmu(delay_onnx, BuildOptions(out=tmp_path / "filtered.fmu", fmi_version=fmi, filter_cutoff=100.0))
    assert float({v.name: v.start for v in read_model_description(str(path)).modelVariables}["filter_cutoff"]) == 100
    inputs = random_inputs(500, seed=3)
    np.testing.assert_allclose(open_fmu(path).simulate(inputs, T), reference.simulate(inputs, T, cutoff=100.0),
                               rtol=RTOL, atol=ATOL)
    with pytest.raises(FmuBuildError, match="filter cut-off"):
        BuildOptions(filter_cutoff=-1.0)


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("ratio", [2.5, 0.4, 3.0])
def test_communication_step_other_than_sample_period(delay_fmus, open_fmu, reference, fmi, ratio):
    inputs = random_inputs(2_000, seed=11)
    params = {"filter_cutoff": 0.0, "output_gain": 2.0}
    got = open_fmu(delay_fmus[fmi]).simulate(inputs, ratio * T, parameters=params)
    expected = reference.simulate(inputs, ratio * T, cutoff=0.0, gain=2.0)
    np.testing.assert_allclose(got, expected, rtol=RTOL, atol=ATOL)
    if ratio < 1:  # holding between samples: some steps evaluate no sample
        assert np.any(np.all(np.diff(got, axis=0) == 0.0, axis=1))


@pytest.mark.parametrize("fmi", [2, 3])
def test_reading_outputs_never_advances_the_state(filtered_fmus, open_fmu, reference, fmi):
    inputs = random_inputs(300, seed=5)
    slave = open_fmu(filtered_fmus[fmi])
    slave.initialize(inputs[0])
    rows = [slave.outputs_now()]
    for n in range(1, len(inputs)):
        slave.set_real(slave.inputs, inputs[n])
        for _ in range(3):
            slave.outputs_now()
            slave.extrapolating()
        slave.do_step((n - 1) * T, T)
        rows.append(slave.outputs_now())
    np.testing.assert_allclose(np.array(rows), reference.simulate(inputs, T, cutoff=100.0), rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("fmi", [2, 3])
def test_rollback_with_get_set_and_serialised_state(delay_fmus, open_fmu, fmi):
    inputs = random_inputs(1_000, seed=3)
    slave = open_fmu(delay_fmus[fmi])
    slave.initialize(inputs[0])
    for n in range(1, 500):
        slave.set_real(slave.inputs, inputs[n])
        slave.do_step((n - 1) * T, T)
    saved = slave.fmu.getFMUState()
    blob = slave.fmu.serializeFMUState(saved)

    def run_on() -> np.ndarray:
        rows, t = [], 499 * T
        for n in range(500, 1_000):
            h = 1.7 * T if n % 2 else 0.3 * T  # steps other than T: samples and holds mixed
            slave.set_real(slave.inputs, inputs[n])
            slave.do_step(t, h)
            t += h
            rows.append(slave.outputs_now())
        return np.array(rows)

    first = run_on()
    slave.fmu.setFMUState(saved)
    second = run_on()
    restored = slave.fmu.deserializeFMUState(blob)
    slave.fmu.setFMUState(restored)
    third = run_on()
    slave.fmu.freeFMUState(saved)
    slave.fmu.freeFMUState(restored)
    np.testing.assert_array_equal(first, second)
    np.testing.assert_array_equal(first, third)


def test_a_state_saved_after_setup_experiment_deserialises_and_a_non_finite_start_is_refused(delay_fmus, open_fmu):
    """Found by test_fuzz.py (seed 2): SetupExperiment kept the start time apart from the time, so a state saved
    between it and initialisation failed the FMU's own plausibility check (time != start + elapsed) when read back."""
    slave = open_fmu(delay_fmus[2])
    slave.fmu.setupExperiment(startTime=5.0)
    saved = slave.fmu.getFMUState()
    restored = slave.fmu.deserializeFMUState(slave.fmu.serializeFMUState(saved))
    slave.fmu.setFMUState(restored)
    slave.fmu.freeFMUState(saved)
    slave.fmu.freeFMUState(restored)
    slave.fmu.enterInitializationMode()
    slave.fmu.exitInitializationMode()
    slave.do_step(5.0, T)
    assert slave.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(5.0 + T)
    other = open_fmu(delay_fmus[2], name="other")
    with pytest.raises(FMICallException):
        other.fmu.setupExperiment(startTime=float("nan"))


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_state_saved_after_terminating_a_failed_initialisation_deserialises(delay_fmus, open_fmu, fmi):
    """Found by test_fuzz.py (seed 5497): a failed initialisation leaves no sample done; terminated so, the FMU's
    state failed its own sample-counter check when read back."""
    slave = open_fmu(delay_fmus[fmi])
    slave.enter_initialization(0.0)
    slave.set_real(["output_gain"], [1e308])  # the first sample's outputs overflow: initialisation fails
    with pytest.raises(FMICallException):
        slave.exit_initialization()
    slave.fmu.terminate()
    saved = slave.fmu.getFMUState()
    restored = slave.fmu.deserializeFMUState(slave.fmu.serializeFMUState(saved))
    slave.fmu.setFMUState(restored)
    slave.fmu.freeFMUState(saved)
    slave.fmu.freeFMUState(restored)


@pytest.mark.parametrize("fmi", [2, 3])
def test_reset_clears_delay_line_and_filter(filtered_fmus, open_fmu, reference, fmi):
    inputs = random_inputs(200, seed=8)
    slave = open_fmu(filtered_fmus[fmi])
    slave.simulate(random_inputs(100, seed=99), T)
    slave.fmu.reset()
    np.testing.assert_allclose(slave.simulate(inputs, T), reference.simulate(inputs, T, cutoff=100.0),
                               rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("fmi", [2, 3])
def test_instances_in_one_process_are_independent(filtered_fmus, open_fmu, reference, fmi):
    a, b = open_fmu(filtered_fmus[fmi], "a"), open_fmu(filtered_fmus[fmi], "b")
    ua, ub = random_inputs(400, seed=21), random_inputs(400, seed=22)
    a.initialize(ua[0])
    b.initialize(ub[0])
    rows_a, rows_b = [a.outputs_now()], [b.outputs_now()]
    for n in range(1, 400):
        a.set_real(a.inputs, ua[n])
        b.set_real(b.inputs, ub[n])
        a.do_step((n - 1) * T, T)
        b.do_step((n - 1) * T, T)
        rows_a.append(a.outputs_now())
        rows_b.append(b.outputs_now())
    np.testing.assert_allclose(rows_a, reference.simulate(ua, T, cutoff=100.0), rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(rows_b, reference.simulate(ub, T, cutoff=100.0), rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("fmi", [2, 3])
def test_extrapolating_flag_and_one_warning_per_excursion(filtered_fmus, open_fmu, reference, fmi):
    slave = open_fmu(filtered_fmus[fmi])
    velocity = [0.0, 0.5, 1.5, 2.0, 1.8, 0.2, 0.1, -3.0, 0.0]  # two excursions: samples 2-4 and 7
    inputs = np.column_stack([velocity, np.zeros(len(velocity))])
    slave.initialize(inputs[0])
    flags = [slave.extrapolating()]
    for n in range(1, len(inputs)):
        slave.set_real(slave.inputs, inputs[n])
        slave.do_step((n - 1) * T, T)
        flags.append(slave.extrapolating())
    assert flags == [False, False, True, True, True, False, False, True, False]
    warnings = [m for status, category, m in slave.messages if category == "logStatusWarning"]
    assert len(warnings) == 2 and all("velocity" in w and "envelope" in w for w in warnings)
    # the value is still computed
    np.testing.assert_allclose(slave.outputs_now(), reference.simulate(inputs, T, cutoff=100.0)[-1], rtol=RTOL,
                               atol=ATOL)


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), float("-inf")])
def test_non_finite_input_is_refused_with_a_message(delay_fmus, open_fmu, fmi, bad):
    slave = open_fmu(delay_fmus[fmi], logging_on=False)
    slave.initialize([0.1, 0.01])
    slave.do_step(0.0, T)
    before = slave.outputs_now()
    with pytest.raises(Exception, match="status 3"):
        slave.set_real(["velocity"], [bad])
    errors = [m for status, category, m in slave.messages if status == 3]
    assert errors and "velocity" in errors[-1] and "finite" in errors[-1]
    assert slave.get_real(["velocity"])[0] == 0.1  # the old value is kept, the FMU still runs
    slave.do_step(T, T)
    assert np.all(np.isfinite(slave.outputs_now())) and slave.outputs_now().shape == before.shape


@pytest.mark.parametrize("fmi", [2, 3])
def test_calls_in_the_wrong_state_and_time_are_refused(delay_fmus, open_fmu, fmi):
    slave = open_fmu(delay_fmus[fmi], logging_on=False)
    with pytest.raises(Exception, match="status 3"):
        slave.do_step(0.0, T)  # before initialisation
    slave.initialize([0.0, 0.0])
    with pytest.raises(Exception, match="status 3"):
        slave.do_step(5 * T, T)  # does not continue from t = 0
    with pytest.raises(Exception, match="status 3"):
        slave.set_real(["filter_cutoff"], [10.0])  # fixed parameter after initialisation
    messages = " | ".join(m for _, _, m in slave.messages)
    assert "must not be called" in messages and "does not continue" in messages and "fixed" in messages


@pytest.mark.parametrize("fmi", [2, 3])
def test_generic_graph_evaluated_once_per_step(generic_onnx, open_fmu, tmp_path, fmi):
    path = build_fmu(generic_onnx, BuildOptions(out=tmp_path / "other.fmu", fmi_version=fmi))
    slave = open_fmu(path)
    assert [v.name for v in slave.description.modelVariables if v.causality == "input"] == ["x[0]", "x[1]", "x[2]"]
    inputs = np.random.default_rng(4).uniform(-1, 1, (50, 3))
    reference = Reference(generic_graph())
    for h in (0.01, 0.037):
        slave.fmu.reset()
        got = slave.simulate(inputs, h, parameters={"filter_cutoff": 5.0})
        np.testing.assert_allclose(got, reference.simulate(inputs, h, cutoff=5.0), rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("fmi", [2, 3])
def test_hostile_names_are_sanitised_and_escaped(open_fmu, tmp_path, fmi):
    onnx_path = tmp_path / "hostile.onnx"
    onnx.save(hostile_graph(), str(onnx_path))
    path = build_fmu(onnx_path, BuildOptions(out=tmp_path / "hostile.fmu", fmi_version=fmi, name='my "model" */'))
    slave = open_fmu(path)
    names = [v.name for v in slave.description.modelVariables]
    assert names.count("time") == (1 if fmi == 3 else 0)
    assert names.count("extrapolating") == 1
    for expected in ("a_b", "c_d_e", "f__g", "line_break", "time_2", "a_b_2", "extrapolating_2", "out_s_"):
        assert expected in names
    assert slave.description.coSimulation.modelIdentifier == "my__model____"
    assert slave.description.modelName == 'my "model" */'
    described = {v.name: v.description for v in slave.description.modelVariables}
    assert "'a\"b'" in described["a_b"]
    inputs = np.random.default_rng(2).uniform(-1, 1, (20, 6))
    got = slave.simulate(inputs, 0.01, parameters={"filter_cutoff": 0.0})
    np.testing.assert_allclose(got, Reference(hostile_graph()).simulate(inputs, 0.01), rtol=RTOL, atol=ATOL)


def test_unsupported_op_fails_the_build_naming_op_node_and_fallback(tmp_path):
    node = helper.make_node("Einsum", ["x", "x"], ["y"], name="odd_node", equation="i,i->i")
    graph = helper.make_graph([node], "g", [helper.make_tensor_value_info("x", onnx.TensorProto.DOUBLE, [2])],
                              [helper.make_tensor_value_info("y", onnx.TensorProto.DOUBLE, [2])])
    onnx_path = tmp_path / "einsum.onnx"
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8), str(onnx_path))
    out = tmp_path / "out" / "einsum.fmu"
    with pytest.raises(FmuBuildError, match=r"(?s)(?=.*Einsum)(?=.*odd_node).*--backend pythonfmu"):
        build_fmu(onnx_path, BuildOptions(out=out))
    assert not out.exists()
    assert not out.parent.exists() or not any(out.parent.iterdir())


def test_compiler_failure_leaves_no_fmu(delay_onnx, tmp_path, monkeypatch):
    out = tmp_path / "broken.fmu"
    monkeypatch.setenv("CC", "gcc -DNN_N_STATE=")  # a real compiler error in the FMU's sources
    with pytest.raises(FmuBuildError, match="C compiler failed"):
        build_fmu(delay_onnx, BuildOptions(out=out))
    assert list(tmp_path.iterdir()) == []


def test_only_fmi_functions_are_exported(delay_fmus, tmp_path):
    for fmi, path in delay_fmus.items():
        with zipfile.ZipFile(path) as archive:
            binary = next(n for n in archive.namelist() if n.startswith("binaries/") and n.endswith(".so"))
            target = tmp_path / f"fmu{fmi}.so"
            target.write_bytes(archive.read(binary))
        listing = subprocess.run(["nm", "-D", "--defined-only", str(target)], capture_output=True, text=True,
                                 check=True).stdout
        symbols = [line.split()[-1] for line in listing.splitlines() if line.split()[1] in "TDBR"]
        assert symbols and all(s.startswith(f"fmi{fmi}") for s in symbols), symbols
        assert binary.startswith("binaries/linux64/" if fmi == 2 else "binaries/x86_64-linux/")


def test_sources_and_build_description_are_shipped(delay_fmus):
    with zipfile.ZipFile(delay_fmus[2]) as archive:
        names = set(archive.namelist())
        build = archive.read("sources/buildDescription.xml").decode()
    for name in ("sources/nn_fmu.c", "sources/nn_fmu.h", "sources/config.h", "sources/graph.c", "sources/graph.h",
                 "sources/fmi2Functions.c", "sources/fmi2Functions.h", "sources/buildDescription.xml"):
        assert name in names
    assert 'modelIdentifier="damper"' in build and 'name="graph.c"' in build
    assert not any("onnx" in n or n.endswith(".py") for n in names)


def test_default_output_is_exported_folder(delay_onnx, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = build_fmu(delay_onnx, BuildOptions(fmi_version=2))
    assert path == Path("exported") / "damper.fmu" and (tmp_path / "exported" / "damper.fmu").is_file()


@pytest.mark.parametrize("fmi", [2, 3])
def test_initialization_preview_and_nonzero_start_time(filtered_fmus, open_fmu, reference, fmi):
    inputs = random_inputs(400, seed=31)
    slave = open_fmu(filtered_fmus[fmi])
    start = 10.0
    slave.enter_initialization(start)
    slave.set_real(slave.inputs, inputs[0] * 0.5)
    slave.outputs_now()  # a preview with other inputs must not leave a trace
    slave.set_real(slave.inputs, inputs[0])
    preview = [slave.outputs_now() for _ in range(3)]
    slave.fmu.exitInitializationMode()
    rows = [slave.outputs_now()]
    t = start
    for n in range(1, len(inputs)):
        slave.set_real(slave.inputs, inputs[n])
        slave.do_step(t, 2.5 * T)
        t += 2.5 * T
        rows.append(slave.outputs_now())
    expected = reference.simulate(inputs, 2.5 * T, cutoff=100.0)
    np.testing.assert_array_equal(preview[0], rows[0])
    np.testing.assert_array_equal(preview[2], rows[0])
    np.testing.assert_allclose(np.array(rows), expected, rtol=RTOL, atol=ATOL)


def test_pythonfmu_backend_is_dispatched_with_the_same_variables(delay_onnx, delay_fmus, tmp_path):
    from fmpy import read_model_description

    path = build_fmu(delay_onnx, BuildOptions(out=tmp_path / "py.fmu", backend="pythonfmu"))
    table = [[(v.name, v.valueReference, v.causality, v.unit) for v in read_model_description(str(p)).modelVariables]
             for p in (path, delay_fmus[2])]
    assert table[0] == table[1]


@pytest.mark.parametrize("fmi", [2, 3])
def test_10000_steps_of_2_5_t_with_a_rollback_match_onnxruntime(filtered_fmus, open_fmu, reference, fmi):
    """The issue's check: 10 000 random steps, h = 2.5 T, with a detour of 1 000 other steps rolled back midway."""
    inputs = random_inputs(10_001, seed=40 + fmi)
    detour = random_inputs(1_000, seed=50, inside=False)
    h = 2.5 * T
    slave = open_fmu(filtered_fmus[fmi])
    slave.initialize(inputs[0])
    rows = [slave.outputs_now()]
    for n in range(1, len(inputs)):
        t = (n - 1) * h  # like fmpy and libcosim: no drift from summing h
        if n == 5_000:
            saved = slave.fmu.getFMUState()
            for m, u in enumerate(detour):
                slave.set_real(slave.inputs, u)
                slave.do_step(t + m * h, h)
            slave.fmu.setFMUState(saved)
            slave.fmu.freeFMUState(saved)
        slave.set_real(slave.inputs, inputs[n])
        slave.do_step(t, h)
        rows.append(slave.outputs_now())
    expected = reference.simulate(inputs, h, cutoff=100.0)
    np.testing.assert_allclose(np.array(rows), expected, rtol=RTOL, atol=ATOL)
