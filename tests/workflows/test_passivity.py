"""The passivity check of bushing networks: a synthetic radial element F = k x + c v at 1 ms, passive for c > 0 and
giving energy back for c < 0 (the chaotic front radial channel of docs/limits.md, in miniature); and one with a 1 ms
Maxwell branch whose velocity term cancels it in the rig's band, passive at 10 Hz but active at 200 Hz (the road
test's axial force network whose full vehicle oscillated when exchanged every 0.1 ms, in miniature)."""

from __future__ import annotations

import numpy as np
import onnx
import pytest

from nnfmu.component import Component, Port, StatePort
from nnfmu.export.graph import GraphBuilder
from nnfmu.workflows.passivity import active_cycles, cycle_energy, passivity_warnings

STIFFNESS = 5.0e6  # [N/m]
REACH = 1.5e-3  # [m] position envelope
RATE_REACH = 0.08  # [m/s] rate envelope


def radial_element(damping: float, sample_period: float | None = 1e-3) -> onnx.ModelProto:
    """Step graph radial_displacement [m], radial_velocity [m/s] -> radial_force = k x + c v [N], T = 1 ms."""
    names = ("radial_displacement", "radial_velocity", "radial_force")
    graph = GraphBuilder(reserved=names)
    spring = graph.node("Mul", ["radial_displacement", graph.constant("k", np.array([STIFFNESS]))], "spring")
    damper = graph.node("Mul", ["radial_velocity", graph.constant("c", np.array([damping]))], "damper")
    graph.output(graph.node("Add", [spring, damper], "sum"), "radial_force")
    model = graph.model("radial", "k x + c v", [(names[0], 1), (names[1], 1)], [(names[2], 1)])
    Component(
        name="radial",
        inputs=[
            Port("radial_displacement", "m", min=-REACH, max=REACH),
            Port("radial_velocity", "m/s", min=-RATE_REACH, max=RATE_REACH),
        ],
        outputs=[Port("radial_force", "N")],
        sample_period=sample_period,
        description="synthetic radial element",
    ).attach_to(model)
    return model


def maxwell_element(damping: float, branch: float, tau: float = 1e-3, offset: float = 0.0) -> onnx.ModelProto:
    """Step graph F = k (x - offset) + c v + d h at T = 1 ms with h the backward-Euler high-pass of x (time constant
    `tau`): K*(w) ~ k + i w (c + d tau / (1 + (w tau)^2)), so c < 0 < c + d tau is passive at low frequency and active
    where w tau ~ 1. Envelope centred on `offset` (a bushing deflected under load)."""
    names = ("radial_displacement", "radial_velocity", "radial_force")
    graph = GraphBuilder(reserved=(*names, "h", "x", "h_next", "x_next"))
    a = graph.constant("a", np.array([tau / (tau + 1e-3)]))
    rise = graph.node("Sub", ["radial_displacement", "x"], "rise")
    h = graph.node("Mul", [graph.node("Add", ["h", rise], "h_sum"), a], "highpass")
    deflection = graph.node("Sub", ["radial_displacement", graph.constant("x0", np.array([offset]))], "deflection")
    terms = [
        graph.node("Mul", [deflection, graph.constant("k", np.array([STIFFNESS]))], "spring"),
        graph.node("Mul", ["radial_velocity", graph.constant("c", np.array([damping]))], "damper"),
        graph.node("Mul", [h, graph.constant("d", np.array([branch]))], "branch"),
    ]
    graph.output(graph.node("Add", [graph.node("Add", terms[:2], "sum2"), terms[2]], "sum"), "radial_force")
    graph.output(h, "h_next")
    graph.output("radial_displacement", "x_next")
    model = graph.model(
        "maxwell",
        "k x + c v + d highpass(x)",
        [(names[0], 1), (names[1], 1), ("h", 1), ("x", 1)],
        [(names[2], 1), ("h_next", 1), ("x_next", 1)],
    )
    Component(
        name="maxwell",
        inputs=[
            Port("radial_displacement", "m", min=offset - REACH, max=offset + REACH),
            Port("radial_velocity", "m/s", min=-RATE_REACH, max=RATE_REACH),
        ],
        outputs=[Port("radial_force", "N")],
        states=[StatePort("h", "h_next", (0.0,), "high-pass [m]"), StatePort("x", "x_next", (0.0,), "x before [m]")],
        sample_period=1e-3,
        description="synthetic radial element with a Maxwell branch",
    ).attach_to(model)
    return model


def test_a_viscous_element_absorbs_pi_c_omega_x_squared_per_cycle():
    damping, amplitude, frequency = 6000.0, 20e-6, 10.0
    cycle = cycle_energy(
        radial_element(damping), "radial_displacement", "radial_velocity", "radial_force", amplitude, frequency
    )
    expected = np.pi * damping * 2.0 * np.pi * frequency * amplitude**2
    assert cycle.energy == pytest.approx(expected, rel=1e-3)
    assert 0.0 < cycle.loss_sine < 0.1


def test_a_passive_element_raises_no_warning():
    assert active_cycles(radial_element(6000.0)) == []
    assert passivity_warnings("radial", radial_element(6000.0)) == []


def test_an_element_giving_energy_back_is_named_with_its_cycle():
    cycles = active_cycles(radial_element(-6000.0))
    assert cycles and all(c.channel == "radial_force" and c.energy < 0.0 for c in cycles)
    (line,) = passivity_warnings("radial", radial_element(-6000.0))
    assert line.startswith("radial: not passive: radial_force:") and "gives back" in line


def test_a_stateless_element_giving_energy_back_is_named_too():
    assert active_cycles(radial_element(-6000.0, sample_period=None))
    assert active_cycles(radial_element(6000.0, sample_period=None)) == []


def test_a_branch_that_only_cancels_the_damping_in_the_band_is_named_at_200_hz():
    """c = -4000, d tau = 5000 N s/m: about +1000 N s/m at 10 Hz, -400 at 100 Hz, -2060 at 200 Hz (w tau = 1.26)."""
    element = maxwell_element(-4000.0, 5.0e6, offset=2e-4)
    low = cycle_energy(element, "radial_displacement", "radial_velocity", "radial_force", 20e-6, 10.0, centre=2e-4)
    high = cycle_energy(element, "radial_displacement", "radial_velocity", "radial_force", 20e-6, 200.0, centre=2e-4)
    assert low.energy > 0.0 > high.energy
    cycles = active_cycles(element)
    assert {c.frequency for c in cycles} == {100.0, 200.0}
    (line,) = passivity_warnings("radial", element)
    assert "at 200 Hz gives back" in line


def test_a_maxwell_branch_adding_damping_is_passive_at_every_frequency():
    assert active_cycles(maxwell_element(1000.0, 5.0e6, offset=2e-4)) == []
