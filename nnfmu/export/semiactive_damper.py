"""An analytic semi-active damper as an nnfmu step graph: F = (c0 + c1·u_f)·v, u_f the command through a lag.

The stand-in for a trained semi-active damper network in closed-loop tests and examples (the skyhook controller,
`nnfmu.control`): the same ports as the `damper-semiactive` preset's FMU bar the displacement (`velocity` [m/s] and
the command, `voltage` [V] or `current` [A], in; `force` [N] out, rebound positive), with a known law, so a closed
loop runs without training. The coil's or valve's lag is first order with time constant tau, exact for a command
held over each sample: u_f,k = u_f,k-1 + a (u_k − u_f,k-1), a = 1 − exp(−T/tau); F_k = (c0 + c1·u_f,k)·v_k.
"""

from __future__ import annotations

import math

import numpy as np
import onnx

from nnfmu.component import Component, Port, StatePort
from nnfmu.errors import SettingsError
from nnfmu.export.graph import GraphBuilder

STATE, STATE_NEXT = "state", "state_next"


def semiactive_damper_graph(
    c0: float = 1000.0,
    c1: float = 600.0,
    tau: float = 0.0053,
    command: str = "voltage",
    unit: str = "V",
    sample_period: float = 1e-3,
    name: str = "semiactive_damper",
) -> onnx.ModelProto:
    """Step graph `velocity` [m/s], `command` [unit] -> `force` = (c0 + c1·u_f)·velocity [N], c0 [N.s/m], c1
    [N.s/m per command unit], lag time constant `tau` [s] (defaults: an MR damper's 1-4 kN.s/m over 0-5 V, coil lag
    5.3 ms); SettingsError naming the value when one is out of range."""
    checks = {
        "c0 [N.s/m]": (c0, c0 >= 0),
        "tau [s]": (tau, tau > 0),
        "sample_period [s]": (sample_period, sample_period > 0),
        f"c1 [N.s/m/{unit}]": (c1, True),
    }
    for what, (value, ok) in checks.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not ok:
            raise SettingsError(
                f"semi-active damper {what} {value!r} is out of range (finite; c0 >= 0, tau and sample_period > 0)"
            )
    if command in ("velocity", "force", STATE):
        raise SettingsError(f"semi-active damper command name {command!r} clashes with its other ports")
    a = 1.0 - math.exp(-sample_period / tau)
    g = GraphBuilder(reserved=("velocity", command, "force", STATE, STATE_NEXT))
    gain, base, slope = (g.constant(n, np.array([v], dtype=float)) for n, v in (("a", a), ("c0", c0), ("c1", c1)))
    lag = g.node("Mul", [g.node("Sub", [command, STATE], "command_minus_lagged"), gain], "lag_increment")
    lagged = g.node("Add", [STATE, lag], "lagged_command")
    damping = g.node("Add", [base, g.node("Mul", [lagged, slope], "controlled_damping")], "damping")
    g.output(g.node("Mul", [damping, "velocity"], "viscous"), "force")
    g.output(lagged, STATE_NEXT)
    doc = f"semi-active damper F = ({c0:g} + {c1:g} u_f) v, u_f = {command} through a {tau:g} s lag"
    model = g.model(name, doc, [("velocity", 1), (command, 1), (STATE, 1)], [("force", 1), (STATE_NEXT, 1)])
    Component(
        name=name,
        inputs=[
            Port("velocity", "m/s", "damper stroke velocity, rebound (extension) positive"),
            Port(command, unit, "damper command (coil voltage or valve current)"),
        ],
        outputs=[Port("force", "N", "damper force, rebound (tension) positive")],
        states=[StatePort(STATE, STATE_NEXT, (0.0,), f"lagged {command} [{unit}]")],
        sample_period=sample_period,
        description=doc,
        metadata={"law": "analytic semi-active damper", "c0": c0, "c1": c1, "tau": tau},
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model
