"""Skyhook controller step graph: the law against an independent numpy form, the FMU against onnxruntime (FMI 2 and
3), the operator set, and the settings' refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import pytest

from nnfmu.component import Component
from nnfmu.control import Command, SkyhookSettings, fixed_command_graph, known_command, skyhook_graph
from nnfmu.cosim.slave import FmuSlave
from nnfmu.errors import SettingsError
from nnfmu.workflows.controller import build_graph_fmu

# The operators the native C backend translates and nnfmu's exporter uses (docs/architecture.md).
NNFMU_OPS = {
    "Add",
    "Sub",
    "Mul",
    "Div",
    "Relu",
    "Constant",
    "Identity",
    "Concat",
    "Slice",
    "Gather",
    "Reshape",
    "Gemm",
    "MatMul",
    "Tanh",
}
T = 1e-3


def _law(s: SkyhookSettings, vb: np.ndarray, vr: np.ndarray) -> np.ndarray:
    """The skyhook law written directly: desired damping, clipped, mapped linearly soft -> hard."""
    desired = s.c_sky * vb * vr / (vr**2 + s.epsilon**2)
    c = np.minimum(np.maximum(desired, s.c_min), s.c_max)
    return s.command.soft + (c - s.c_min) / (s.c_max - s.c_min) * (s.command.hard - s.command.soft)


def _sensors(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Body and stroke velocities [m/s] over every sign quadrant, near-zero strokes and exact zeros."""
    rng = np.random.default_rng(3)
    vb, vr = rng.normal(0.0, 0.2, n), rng.normal(0.0, 0.3, n)
    vr[::7] *= 1e-3
    vb[::11], vr[::13] = 0.0, 0.0
    return vb, vr


def _onnxruntime(model: onnx.ModelProto, vb: np.ndarray, vr: np.ndarray, out: str) -> np.ndarray:
    session = ort.InferenceSession(model.SerializeToString())
    return np.array([session.run([out], {"body_velocity": [b], "damper_velocity": [r]})[0][0] for b, r in zip(vb, vr)])


SETTINGS = {
    "mr": SkyhookSettings(),
    # a CDC valve that softens with more current: the command runs from 1.8 A at c_min down to 0.3 A at c_max
    "cdc-reversed": SkyhookSettings(
        c_sky=5000,
        c_min=800,
        c_max=3000,
        epsilon=0.02,  # ints: float64 constants
        command=known_command("current", soft=1.8, hard=0.3),
    ),
}


@pytest.mark.parametrize("name", SETTINGS)
def test_graph_equals_the_law_and_spans_the_command_range(name: str) -> None:
    s = SETTINGS[name]
    vb, vr = _sensors(400)
    got = _onnxruntime(skyhook_graph(s), vb, vr, s.command.name)
    np.testing.assert_allclose(got, _law(s, vb, vr), rtol=1e-13, atol=1e-13)
    soft, hard = s.command.soft, s.command.hard
    assert np.all((got - soft) * (got - hard) <= 1e-12)  # within the range, whichever way it runs
    assert np.any(got == soft) and np.any(np.isclose(got, hard, rtol=0, atol=1e-12))
    assert np.any(np.abs(got - soft) * np.abs(got - hard) > 1e-6)  # and between
    opposing = vb * vr <= 0.0  # no skyhook force to be had: the damper goes soft
    np.testing.assert_array_equal(got[opposing], soft)


def test_graph_uses_only_the_native_backends_operators_and_describes_its_ports() -> None:
    model = skyhook_graph(SkyhookSettings(command=known_command("current")))
    assert {node.op_type for node in model.graph.node} <= NNFMU_OPS
    component = Component.from_onnx(model)
    assert [(p.name, p.unit) for p in component.inputs] == [("body_velocity", "m/s"), ("damper_velocity", "m/s")]
    assert [(p.name, p.unit) for p in component.outputs] == [("current", "A")]
    assert component.sample_period == T and component.states == []
    assert component.metadata["settings"]["c_sky"] == 3000.0


def _fmu_outputs(fmu: Path, vb: np.ndarray, vr: np.ndarray, out: str) -> np.ndarray:
    """The FMU's command after initialisation (sample 0, inputs row 0) and after each 1 ms step (sample k, inputs
    row k set before the step)."""
    with FmuSlave(fmu) as slave:
        slave.enter_initialization(0.0)
        slave.set_real(["body_velocity", "damper_velocity"], [vb[0], vr[0]])
        slave.exit_initialization()
        rows = [slave.get_real([out])[0]]
        for k in range(1, len(vb)):
            slave.set_real(["body_velocity", "damper_velocity"], [vb[k], vr[k]])
            slave.do_step((k - 1) * T, T)
            rows.append(slave.get_real([out])[0])
    return np.array(rows)


@pytest.mark.parametrize("fmi", [2, 3])
def test_fmu_equals_onnxruntime(tmp_path: Path, fmi: int) -> None:
    s = SETTINGS["cdc-reversed"] if fmi == 3 else SETTINGS["mr"]
    model = skyhook_graph(s)
    fmu = build_graph_fmu(model, tmp_path / "skyhook.fmu", fmi)
    vb, vr = _sensors(300)
    expected = _onnxruntime(model, vb, vr, s.command.name)
    got = _fmu_outputs(fmu, vb, vr, s.command.name)
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-14)
    assert np.ptp(got) > 0.5 * abs(s.command.hard - s.command.soft)


def test_fixed_command_holds_its_value(tmp_path: Path) -> None:
    model = fixed_command_graph(known_command("voltage"), 2.5)
    assert {node.op_type for node in model.graph.node} <= NNFMU_OPS
    vb, vr = _sensors(20)
    np.testing.assert_array_equal(_onnxruntime(model, vb, vr, "voltage"), 2.5)
    np.testing.assert_array_equal(_fmu_outputs(build_graph_fmu(model, tmp_path / "fixed.fmu"), vb, vr, "voltage"), 2.5)
    with pytest.raises(SettingsError, match="fixed command voltage nan V"):
        fixed_command_graph(known_command("voltage"), float("nan"))
    with pytest.raises(SettingsError, match="fixed command sample_period 0 s"):
        fixed_command_graph(known_command("voltage"), 1.0, sample_period=0)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"c_sky": -1.0}, r"c_sky -1\.0 N\.s/m must be a finite number >= 0"),
        ({"c_min": float("inf")}, r"c_min inf N\.s/m"),
        ({"c_max": 1000.0}, r"c_max 1000\.0 N\.s/m must be a finite number > 1000"),
        ({"epsilon": 0.0}, r"epsilon 0\.0 m/s must be a finite number > 0"),
        ({"sample_period": 0.0}, r"sample_period 0\.0 s"),
        ({"sample_period": 1e5}, r"sample_period 100000\.0 s must be at most"),
        ({"c_sky": True}, r"c_sky True"),
        ({"command": "voltage"}, r"command 'voltage' must be a Command"),
    ],
)
def test_settings_refuse_bad_values_naming_them(changes: dict, message: str) -> None:
    with pytest.raises(SettingsError, match=message):
        SkyhookSettings(**changes)


def test_commands_refuse_bad_names_units_and_ranges() -> None:
    with pytest.raises(SettingsError, match="unknown damper command 'torque'"):
        known_command("torque")
    with pytest.raises(SettingsError, match="command name 'damper_velocity'"):
        Command("damper_velocity", "V", 0.0, 5.0)
    with pytest.raises(SettingsError, match=r"command name 'a b'"):
        Command("a b", "V", 0.0, 5.0)
    with pytest.raises(SettingsError, match="the unit '' must be named"):
        Command("voltage", "", 0.0, 5.0)
    with pytest.raises(SettingsError, match="soft and hard command are both 1.0 A"):
        known_command("current", soft=1.0, hard=1.0)
    with pytest.raises(SettingsError, match="hard command nan V"):
        known_command("voltage", hard=float("nan"))
    assert known_command("current") == Command("current", "A", 0.3, 1.8)
