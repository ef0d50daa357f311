"""The rigs' truth physics as step graphs, so that it runs as component FMUs in the road test's co-simulation.

With these FMUs in the networks' place, a co-simulation differs from the monolithic reference only by the coupling
and the sampling (the error budget's `nrmse_coupling`), because both integrate the same laws:

- damper (`DamperTruth`: valve with series compliance, seal friction, optionally gas force): the valve force obeys
  F' = k_s (v - w(F)), w the valve speed that carries F, integrated with `substeps` classic Runge-Kutta steps per
  sample, the velocity linear between samples (the monolithic reference's RK4 sees it continuous); w is the closed-form
  inverse of the digressive characteristic (`ValveSide.speed`), branch-free: rebound speed of relu(F) minus jounce
  speed of relu(-F), each the larger root of its quadratic;
- bushing channel (`BushingChannelTruth`: progressive spring, Maxwell branches, Jenkins elements): exact for a
  deflection linear between samples, as the bushing rig records it: Maxwell branches as first-order recursions,
  Jenkins elements as play operators, clip(y, -s, s) = y - relu(y - s) + relu(-y - s). The first sample finds the
  bushing relaxed where it stands (`BushingChannelTruth.simulate`, and the monolithic reference's rest state), not
  moved there from zero deflection: a car starts on deflected bushings, and a step from zero loaded the Jenkins
  elements that never slip again on a road (the co-simulation's front radial bushing force stood 1.2 N off the
  reference for the whole drive, its deflection 30 %).

Ports are named like the networks' (`velocity`, `displacement`, `force`; `axial_displacement`, ..., `conical_torque`),
so `nnfmu.cosim.ssp.connect_by_name` wires them to the vehicle as it wires the networks.
"""

from __future__ import annotations

import numpy as np
import onnx

from nnfmu.component import Component, Port, StatePort
from nnfmu.data.rigs import BUSHING_CHANNELS, BushingChannelTruth, DamperTruth
from nnfmu.errors import NnfmuError
from nnfmu.export.graph import GraphBuilder
from nnfmu.physics.damper import ValveSide

STARTED, STARTED_NEXT = "started", "started_next"  # bushing truth: 0 at the first sample, 1 afterwards
DAMPER_SUBSTEPS = 10  # RK4 steps per sample: 0.1 ms at 1 kHz, the monolithic reference's step


class TruthGraphError(NnfmuError, ValueError):
    """The truth physics asked for cannot be written as a step graph; the message names the effect."""


def _speed(graph: GraphBuilder, force: str, side: ValveSide, name: str) -> str:
    """Speed [m/s] at which `side` carries `force` >= 0 [N] (a (1,) tensor): the larger root of the quadratic
    a u^2 + b u + c = 0 of `ValveSide.speed`, clipped at 0."""
    fh = graph.node("Add", [force, graph.constant(f"{name}_offset", np.array([side.offset]))], f"{name}_shifted")
    fb = side.blow_off
    # b = c_low (fb - fh) - c_high fh = c_low fb - (c_low + c_high) fh;  c = -fh (fb - fh) - r^2 = fh^2 - fb fh - r^2
    b = graph.node(
        "Sub",
        [
            graph.constant(f"{name}_b0", np.array([side.c_low * fb])),
            graph.node(
                "Mul", [fh, graph.constant(f"{name}_b1", np.array([side.c_low + side.c_high]))], f"{name}_b_slope"
            ),
        ],
        f"{name}_b",
    )
    fh_squared = graph.node("Mul", [fh, fh], f"{name}_fh_squared")
    c = graph.node(
        "Sub",
        [
            fh_squared,
            graph.node(
                "Add",
                [
                    graph.node("Mul", [fh, graph.constant(f"{name}_fb", np.array([fb]))], f"{name}_fb_fh"),
                    graph.constant(f"{name}_r2", np.array([side.rounding**2])),
                ],
                f"{name}_c_rest",
            ),
        ],
        f"{name}_c",
    )
    a = side.c_low * side.c_high
    discriminant = graph.node(
        "Sub",
        [
            graph.node("Mul", [b, b], f"{name}_b_squared"),
            graph.node("Mul", [c, graph.constant(f"{name}_4a", np.array([4 * a]))], f"{name}_4ac"),
        ],
        f"{name}_discriminant",
    )
    root = graph.node("Sqrt", [graph.node("Relu", [discriminant], f"{name}_real")], f"{name}_root")
    u = graph.node(
        "Mul",
        [graph.node("Sub", [root, b], f"{name}_numerator"), graph.constant(f"{name}_half_a", np.array([0.5 / a]))],
        f"{name}_u",
    )
    return graph.node("Relu", [u], f"{name}_speed")


def _valve_rate(graph: GraphBuilder, truth: DamperTruth, valve: str, velocity: str, name: str) -> str:
    """dF/dt = k_s (v - w(F)) of the valve force `valve` at piston velocity `velocity`."""
    p = truth.params
    rebound = _speed(graph, graph.node("Relu", [valve], f"{name}_rebound_force"), p.rebound, f"{name}_rebound")
    jounce = _speed(
        graph,
        graph.node(
            "Relu",
            [graph.node("Mul", [valve, graph.constant(f"{name}_minus", np.array([-1.0]))], f"{name}_negated")],
            f"{name}_jounce_force",
        ),
        p.jounce,
        f"{name}_jounce",
    )
    w = graph.node("Sub", [rebound, jounce], f"{name}_valve_speed")
    return graph.node(
        "Mul",
        [
            graph.node("Sub", [velocity, w], f"{name}_slip"),
            graph.constant(f"{name}_ks", np.array([p.series_stiffness])),
        ],
        f"{name}_rate",
    )


def damper_truth_graph(truth: DamperTruth, sample_period: float, substeps: int = DAMPER_SUBSTEPS) -> onnx.ModelProto:
    """Step graph of the damper truth: inputs `velocity` [m/s] (and `displacement` [m] with gas force), output
    `force` [N] (tension positive), state [v_{k-1}, valve force]."""
    unsupported = sorted(set(truth.effects) - {"hysteresis", "seal_friction", "gas_force"})
    if unsupported:
        raise TruthGraphError(
            f"damper truth graph: effect(s) {', '.join(unsupported)} not supported (the vehicle's "
            "truth damper has hysteresis, seal friction and gas force at most)"
        )
    if "hysteresis" not in truth.effects:
        raise TruthGraphError("damper truth graph: without 'hysteresis' the valve force is algebraic; not supported")
    gas = "gas_force" in truth.effects
    reserved = ["velocity", "state", "force", "state_next"] + (["displacement"] if gas else [])
    graph = GraphBuilder(reserved=reserved)
    zero = graph.constant("zero_index", np.array([0], dtype=np.int64))
    one = graph.constant("one_index", np.array([1], dtype=np.int64))
    two = graph.constant("two_index", np.array([2], dtype=np.int64))
    v_start = graph.node("Slice", ["state", zero, one], "velocity_before")
    valve = graph.node("Slice", ["state", one, two], "valve_force_before")
    dv = graph.node("Sub", ["velocity", v_start], "velocity_change")
    h = sample_period / substeps
    for j in range(substeps):

        def v_at(fraction: float, tag: str) -> str:
            return graph.node(
                "Add",
                [
                    v_start,
                    graph.node("Mul", [dv, graph.constant(f"{tag}_fraction", np.array([fraction]))], f"{tag}_ramp"),
                ],
                f"{tag}_velocity",
            )

        tag = f"s{j}"
        v0, vm, v1 = (
            v_at(j / substeps, f"{tag}_a"),
            v_at((j + 0.5) / substeps, f"{tag}_m"),
            v_at((j + 1) / substeps, f"{tag}_b"),
        )
        half, full = graph.constant(f"{tag}_half_h", np.array([h / 2])), graph.constant(f"{tag}_h", np.array([h]))
        k1 = _valve_rate(graph, truth, valve, v0, f"{tag}_k1")

        def stage(k_prev: str, step: str, v: str, i: int) -> str:
            """RK4 stage i: the valve rate at valve + step * k_prev (node names as before)."""
            valve_i = graph.node("Add", [valve, graph.node("Mul", [k_prev, step], f"{tag}_d{i - 1}")], f"{tag}_f{i}")
            return _valve_rate(graph, truth, valve_i, v, f"{tag}_k{i}")

        k2 = stage(k1, half, vm, 2)
        k3 = stage(k2, half, vm, 3)
        k4 = stage(k3, full, v1, 4)
        inner = graph.node(
            "Add",
            [
                graph.node("Add", [k1, k4], f"{tag}_ends"),
                graph.node(
                    "Mul",
                    [graph.node("Add", [k2, k3], f"{tag}_middles"), graph.constant(f"{tag}_two", np.array([2.0]))],
                    f"{tag}_twice",
                ),
            ],
            f"{tag}_sum",
        )
        valve = graph.node(
            "Add",
            [valve, graph.node("Mul", [inner, graph.constant(f"{tag}_sixth", np.array([h / 6]))], f"{tag}_increment")],
            f"{tag}_valve_force",
        )
    p = truth.params
    force = valve
    if "seal_friction" in truth.effects:
        sign = graph.node(
            "Tanh",
            [
                graph.node(
                    "Mul",
                    ["velocity", graph.constant("friction_scale", np.array([1.0 / p.friction_velocity]))],
                    "friction_argument",
                )
            ],
            "friction_sign",
        )
        force = graph.node(
            "Add",
            [
                force,
                graph.node("Mul", [sign, graph.constant("friction_level", np.array([p.seal_friction]))], "friction"),
            ],
            "with_friction",
        )
    if gas:
        pushed = graph.node(
            "Sub",
            [
                graph.constant("gas_preload", np.array([p.gas_preload])),
                graph.node("Mul", ["displacement", graph.constant("gas_rate", np.array([p.gas_rate]))], "gas_spring"),
            ],
            "gas",
        )
        force = graph.node("Sub", [force, pushed], "with_gas")
    graph.output(force, "force")
    graph.output(graph.node("Concat", ["velocity", valve], "next_state", axis=0), "state_next")
    inputs = [("velocity", 1), ("state", 2)] + ([("displacement", 1)] if gas else [])
    model = graph.model(
        "damper_truth", f"damper truth physics ({', '.join(truth.effects)})", inputs, [("force", 1), ("state_next", 2)]
    )
    ports = [Port("velocity", "m/s", "piston velocity, rebound positive")]
    if gas:
        ports.append(Port("displacement", "m", "piston displacement from mid-stroke, rebound positive"))
    Component(
        name="damper_truth",
        inputs=ports,
        outputs=[Port("force", "N", "damper force, tension positive")],
        states=[StatePort("state", "state_next", (0.0, 0.0), "velocity at the sample before [m/s], valve force [N]")],
        sample_period=sample_period,
        description=f"damper truth physics ({', '.join(truth.effects)}), {substeps} RK4 steps per sample",
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model


def _clip(graph: GraphBuilder, y: str, limit: str, name: str) -> str:
    """clip(y, -limit, limit) element-wise, from Relu."""
    over = graph.node("Relu", [graph.node("Sub", [y, limit], f"{name}_above")], f"{name}_over")
    negated = graph.node("Mul", [y, graph.constant(f"{name}_minus", np.array([-1.0]))], f"{name}_negated")
    under = graph.node("Relu", [graph.node("Sub", [negated, limit], f"{name}_below")], f"{name}_under")
    return graph.node("Add", [graph.node("Sub", [y, over], f"{name}_capped"), under], name)


def bushing_truth_graph(truths: dict[str, BushingChannelTruth], sample_period: float) -> onnx.ModelProto:
    """Step graph of a bushing's channels (`truths` keyed like `BUSHING_CHANNELS`: 'axial', 'radial',
    'axial_rotation', 'conical_rotation'): each channel's position input, force or torque output, and a state of
    [position before, Maxwell branch forces, Jenkins element forces], and one `started` flag (0 at the first sample,
    which takes no position change, then 1)."""
    unknown = sorted(set(truths) - set(BUSHING_CHANNELS))
    if unknown:
        raise TruthGraphError(
            f"bushing truth graph: unknown channel(s) {', '.join(unknown)} (known: {', '.join(BUSHING_CHANNELS)})"
        )
    reserved = [
        name
        for key in truths
        for name in (BUSHING_CHANNELS[key].position, BUSHING_CHANNELS[key].force, f"{key}_state", f"{key}_state_next")
    ] + [STARTED, STARTED_NEXT]
    graph = GraphBuilder(reserved=reserved)
    graph.output(graph.node("Identity", [graph.constant("after_start", np.ones(1))], "started_after"), STARTED_NEXT)
    inputs, outputs, ports_in, ports_out, states = [(STARTED, 1)], [(STARTED_NEXT, 1)], [], [], []
    states.append(StatePort(STARTED, STARTED_NEXT, (0.0,), "0 before the first sample, then 1"))
    for key, truth in truths.items():
        channel = BUSHING_CHANNELS[key]
        stiffness, relaxation = truth.maxwell
        iwan_k, iwan_slip = truth.iwan
        nm, nf = len(stiffness), len(iwan_k)
        size = 1 + nm + nf
        state, state_next = f"{key}_state", f"{key}_state_next"
        edges = [graph.constant(f"{key}_edge{i}", np.array([i], dtype=np.int64)) for i in (0, 1, 1 + nm, size)]
        before = graph.node("Slice", [state, edges[0], edges[1]], f"{key}_position_before")
        step = graph.node(
            "Mul",
            [graph.node("Sub", [channel.position, before], f"{key}_position_moved"), STARTED],
            f"{key}_position_change",
        )
        x = channel.position
        cube = graph.node("Mul", [graph.node("Mul", [x, x], f"{key}_squared"), x], f"{key}_cubed")
        total = graph.node(
            "Add",
            [
                graph.node(
                    "Mul", [x, graph.constant(f"{key}_k1", np.array([truth.params.stiffness]))], f"{key}_linear"
                ),
                graph.node(
                    "Mul",
                    [cube, graph.constant(f"{key}_k3", np.array([truth.params.cubic_stiffness]))],
                    f"{key}_progressive",
                ),
            ],
            f"{key}_elastic",
        )
        parts = [channel.position]
        if nm:
            decay = np.exp(-sample_period / relaxation)
            gain = stiffness * relaxation * (1 - decay) / sample_period
            z = graph.node("Slice", [state, edges[1], edges[2]], f"{key}_maxwell_before")
            z = graph.node(
                "Add",
                [
                    graph.node("Mul", [z, graph.constant(f"{key}_decay", decay)], f"{key}_decayed"),
                    graph.node("Mul", [step, graph.constant(f"{key}_gain", gain)], f"{key}_loaded"),
                ],
                f"{key}_maxwell",
            )
            total = graph.node(
                "Add",
                [
                    total,
                    graph.node(
                        "MatMul", [z, graph.constant(f"{key}_sum_maxwell", np.ones((nm, 1)))], f"{key}_maxwell_sum"
                    ),
                ],
                f"{key}_with_maxwell",
            )
            parts.append(z)
        if nf:
            f = graph.node("Slice", [state, edges[2], edges[3]], f"{key}_jenkins_before")
            trial = graph.node(
                "Add",
                [f, graph.node("Mul", [step, graph.constant(f"{key}_iwan_k", iwan_k)], f"{key}_jenkins_load")],
                f"{key}_jenkins_trial",
            )
            f = _clip(graph, trial, graph.constant(f"{key}_iwan_slip", iwan_slip), f"{key}_jenkins")
            total = graph.node(
                "Add",
                [
                    total,
                    graph.node(
                        "MatMul", [f, graph.constant(f"{key}_sum_jenkins", np.ones((nf, 1)))], f"{key}_jenkins_sum"
                    ),
                ],
                f"{key}_with_jenkins",
            )
            parts.append(f)
        graph.output(total, channel.force)
        graph.output(graph.node("Concat", parts, f"{key}_next", axis=0), state_next)
        inputs += [(channel.position, 1), (state, size)]
        outputs += [(channel.force, 1), (state_next, size)]
        ports_in.append(Port(channel.position, channel.position_unit, f"bushing {key} deflection"))
        ports_out.append(Port(channel.force, channel.force_unit, f"bushing {key} force or torque"))
        states.append(StatePort(state, state_next, (0.0,) * size, f"{key}: position before, Maxwell, Jenkins"))
    model = graph.model("bushing_truth", "bushing truth physics per channel", inputs, outputs)
    Component(
        name="bushing_truth",
        inputs=ports_in,
        outputs=ports_out,
        states=states,
        sample_period=sample_period,
        description="bushing truth physics: progressive spring, Maxwell branches, Jenkins elements; exact for "
        "a deflection linear between samples",
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model
