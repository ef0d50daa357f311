"""The passivity check of bushing networks: a synthetic radial element F = k x + c v at 1 ms, passive for c > 0 and
giving energy back for c < 0 (the chaotic front radial channel of docs/limits.md, in miniature)."""

from __future__ import annotations

import numpy as np
import onnx
import pytest

from nnfmu.component import Component, Port
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
