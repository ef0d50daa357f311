"""The analytic semi-active damper step graph: its lag against the exact first-order response, its FMU against
onnxruntime, and its refusals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest

from nnfmu.cosim.slave import FmuSlave
from nnfmu.errors import SettingsError
from nnfmu.export.semiactive_damper import semiactive_damper_graph
from nnfmu.workflows.controller import build_graph_fmu

T = 1e-3


def _onnxruntime(command: str, velocity: np.ndarray, u: np.ndarray, **law: float) -> np.ndarray:
    session = ort.InferenceSession(semiactive_damper_graph(command=command, **law).SerializeToString())
    state, forces = np.zeros(1), []
    for v, c in zip(velocity, u):
        force, state = session.run(None, {"velocity": [v], command: [c], "state": state})
        forces.append(force[0])
    return np.array(forces)


def test_a_held_command_step_reaches_the_force_through_the_exact_lag() -> None:
    """Command stepped to 5 V at sample 0, velocity 0.2 m/s: u_f,k = 5 (1 - exp(-(k+1) T / tau)) exactly."""
    c0, c1, tau, n = 1000.0, 600.0, 0.0053, 50
    got = _onnxruntime("voltage", np.full(n, 0.2), np.full(n, 5.0), c0=c0, c1=c1, tau=tau)
    lagged = 5.0 * (1.0 - np.exp(-(np.arange(n) + 1) * T / tau))
    np.testing.assert_allclose(got, (c0 + c1 * lagged) * 0.2, rtol=1e-12)
    controlled = got - c0 * 0.2  # the command's part of the force: 17 % of its end value after one of 5.3 ms
    assert controlled[-1] > 0.99 * c1 * 5.0 * 0.2 and controlled[0] < 0.2 * controlled[-1]


@pytest.mark.parametrize("fmi", [2, 3])
def test_fmu_equals_onnxruntime(tmp_path: Path, fmi: int) -> None:
    rng = np.random.default_rng(5)
    n = 200
    velocity, current = rng.normal(0.0, 0.3, n), rng.uniform(0.3, 1.8, n)
    law = {"c0": 800, "c1": 1500, "tau": 0.008}  # ints must still give float64 constants (the C backend's only kind)
    expected = _onnxruntime("current", velocity, current, **law)
    fmu = build_graph_fmu(semiactive_damper_graph(command="current", unit="A", **law), tmp_path / "damper.fmu", fmi)
    with FmuSlave(fmu) as slave:
        assert slave.unit("current") == "A" and slave.unit("force") == "N"
        slave.enter_initialization(0.0)
        slave.set_real(["velocity", "current"], [velocity[0], current[0]])
        slave.exit_initialization()
        got = [slave.get_real(["force"])[0]]
        for k in range(1, n):
            slave.set_real(["velocity", "current"], [velocity[k], current[k]])
            slave.do_step((k - 1) * T, T)
            got.append(slave.get_real(["force"])[0])
    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-9)


@pytest.mark.parametrize(
    ("law", "message"),
    [
        ({"c0": -1.0}, r"c0 \[N\.s/m\] -1\.0"),
        ({"tau": 0.0}, r"tau \[s\] 0\.0"),
        ({"c1": math.nan}, r"c1 \[N\.s/m/V\]"),
        ({"command": "force"}, "command name 'force' clashes"),
    ],
)
def test_bad_laws_are_refused_naming_the_value(law: dict, message: str) -> None:
    with pytest.raises(SettingsError, match=message):
        semiactive_damper_graph(**law)
