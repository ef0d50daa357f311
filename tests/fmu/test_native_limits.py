"""The native FMU under careless and hostile use: its work per call is bounded, its clock never loses samples, a value
that would be wrong is an error, forged states are refused, and a master can roll back after an error."""

from __future__ import annotations

import struct
import time
from pathlib import Path

import numpy as np
import onnx
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from native_fmu_helpers import SAMPLE_PERIOD, Reference, delay_step_graph

from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.options import BuildOptions

pytestmark = pytest.mark.slow  # its FMUs built for FMI 2 and 3 with the win64 DLL, 11-15 s of fixtures

T = SAMPLE_PERIOD
ERROR = 3


def _errors(slave) -> str:  # noqa: ANN001 (ProbeSlave)
    return " | ".join(message for status, _, message in slave.messages if status >= ERROR)


@pytest.fixture(scope="module")
def damper_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    """A linear damper F = 1000 N.s/m * v sampled every 1 ms, FMI 2 and 3 (no envelope: any finite input is used)."""
    folder = tmp_path_factory.mktemp("limits")
    onnx.save(linear_damper_graph(1000.0, sample_period=T), folder / "damper.onnx")
    return {
        v: build_fmu(folder / "damper.onnx", BuildOptions(out=folder / f"damper{v}.fmu", fmi_version=v)) for v in (2, 3)
    }


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("h", [1e308, 1e6])
def test_a_step_of_too_many_samples_is_refused_at_once_naming_the_limit(damper_fmus, open_fmu, fmi, h):
    slave = open_fmu(damper_fmus[fmi])
    slave.initialize([0.1])
    started = time.perf_counter()
    with pytest.raises(FMICallException):
        slave.do_step(0.0, h)
    assert time.perf_counter() - started < 1.0
    assert "more than the 1000000 one step may evaluate" in _errors(slave)
    slave.do_step(0.0, T)  # the refused call changed nothing: the FMU steps on
    assert slave.outputs_now()[0] == pytest.approx(100.0)


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_unix_clock_start_time_evaluates_one_sample_per_sample_step(delay_fmus, open_fmu, fmi):
    """At t_start = 1.7e9 s the float times of the steps are 2.4e-7 s apart from exact: the samples are counted from
    the elapsed time, so every 1 ms step evaluates exactly one sample, as from t_start = 0."""
    rng = np.random.default_rng(4)
    inputs = np.column_stack([rng.uniform(-1, 1, 2_001), rng.uniform(-0.1, 0.1, 2_001)])
    got = open_fmu(delay_fmus[fmi]).simulate(inputs, T, start=1.7e9)
    np.testing.assert_allclose(got, Reference(delay_step_graph()).simulate(inputs, T), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("fmi", [2, 3])
def test_an_output_that_overflows_is_an_error_and_a_rollback_recovers(damper_fmus, open_fmu, fmi):
    slave = open_fmu(damper_fmus[fmi])
    slave.initialize([1.0], parameters={"output_gain": 1e300})
    assert slave.outputs_now()[0] == pytest.approx(1e303)
    saved = slave.get_state()
    slave.set_real(["velocity"], [1e10])  # finite, but gain * force = 1e313 is not
    with pytest.raises(FMICallException):
        slave.do_step(0.0, T)
    assert "output 'force' of sample 1 is inf" in _errors(slave) and "output_gain 1e+300" in _errors(slave)
    with pytest.raises(FMICallException):
        slave.do_step(0.0, T)  # failed: no step before a rollback or reset
    slave.set_state(saved)  # FMI allows rolling back to a saved state after an error
    slave.set_real(["velocity"], [2.0])
    slave.do_step(0.0, T)
    assert slave.outputs_now()[0] == pytest.approx(2e303)
    slave.free_state(saved)


def _forged(blob: bytes, value: float, forged: float) -> bytes:
    """`blob` with the one float64 field holding `value` replaced by `forged`."""
    field = struct.pack("<d", value)
    assert blob.count(field) == 1, "the field to forge must be unique in the state"
    return blob.replace(field, struct.pack("<d", forged))


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize(
    ("field", "forged", "named"),
    [
        ("time", 1e300, "time"),
        ("time", float("nan"), "time"),
        ("gain", float("nan"), "output_gain"),
        ("gain", float("inf"), "output_gain"),
    ],
)
def test_a_forged_serialised_state_is_refused_naming_the_field(damper_fmus, open_fmu, fmi, field, forged, named):
    slave = open_fmu(damper_fmus[fmi])
    slave.initialize([0.5], start=0.25, parameters={"output_gain": 1.2345})
    for n in range(37):
        slave.do_step(0.25 + n * 0.0173, 0.0173)  # t = 0.8901 s, a value no other field holds (elapsed: 0.6401 s)
    saved = slave.get_state()
    blob = bytes(slave.fmu.serializeFMUState(saved))
    value = {"time": 0.25 + 36 * 0.0173 + 0.0173, "gain": 1.2345}[field]  # the last point plus its step
    with pytest.raises(FMICallException):
        slave.fmu.deserializeFMUState(_forged(blob, value, forged))
    assert f"the state's {named} is not one this FMU can have" in _errors(slave)
    restored = slave.fmu.deserializeFMUState(blob)  # the genuine bytes still load
    slave.set_state(restored)
    slave.free_state(restored)
    slave.free_state(saved)


def test_the_internal_time_is_no_fmi2_variable(damper_fmus, open_fmu):
    two, three = open_fmu(damper_fmus[2], "two"), open_fmu(damper_fmus[3], "three")
    time_vr = {v.name: v.valueReference for v in read_model_description(str(damper_fmus[3])).modelVariables}["time"]
    for slave in (two, three):
        slave.initialize([0.0])
        slave.do_step(0.0, T)
    assert three.fmu.getFloat64([time_vr]) == [pytest.approx(T)]
    with pytest.raises(FMICallException):
        two.fmu.getReal([time_vr])
    assert f"value reference {time_vr} is not a Real variable" in _errors(two)


def test_a_sampled_fmu_refuses_input_derivatives(damper_fmus, open_fmu):
    assert read_model_description(str(damper_fmus[2])).coSimulation.canInterpolateInputs is False
    slave = open_fmu(damper_fmus[2])
    slave.initialize([0.0])
    with pytest.raises(FMICallException):
        slave.fmu.setRealInputDerivatives([slave.value_references(["velocity"])[0]], [1], [3.0])
    assert "cannot interpolate them" in _errors(slave)


@pytest.mark.parametrize("period", [1e-300, float("inf"), "0.001"])
def test_an_impossible_sample_period_is_refused_at_build(tmp_path, period):
    model = linear_damper_graph(1000.0, sample_period=T)
    text = next(p for p in model.metadata_props if p.key == "nnfmu.component")
    text.value = text.value.replace(
        '"sample_period": 0.001', f'"sample_period": {period!r}'.replace("'", '"').replace("inf", "1e999")
    )
    onnx.save(model, tmp_path / "odd.onnx")
    with pytest.raises(FmuBuildError, match="sample period .* must be a number from 1e-09 to 10000 s"):
        build_fmu(tmp_path / "odd.onnx", BuildOptions(out=tmp_path / "odd.fmu"))
    assert not (tmp_path / "odd.fmu").exists()
