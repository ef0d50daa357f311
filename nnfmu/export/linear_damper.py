"""A linear viscous damper F = c·v as an nnfmu step graph: the baseline component for coupling studies.

With a linear component the co-simulation error against the monolithic solution is the coupling error alone, which
is how the master's schemes are measured (`bench/cosim_coupling.py`, tests/cosim, tests/workflows/roadtest).
"""

from __future__ import annotations

import numpy as np
import onnx

from nnfmu.component import Component, Port
from nnfmu.export.graph import GraphBuilder


def linear_damper_graph(
    damping: float,
    sample_period: float | None = None,
    name: str = "damper",
    velocity_range: tuple[float, float] | None = None,
) -> onnx.ModelProto:
    """Step graph `velocity` [m/s] -> `force` = damping·velocity [N] (damping in N.s/m).

    `sample_period` None makes it stateless (evaluated once per communication step); `velocity_range` is the
    envelope given to the velocity port.
    """
    graph = GraphBuilder(reserved=("velocity", "force"))
    graph.output(graph.node("Mul", ["velocity", graph.constant("c", np.array([damping]))], "viscous"), "force")
    model = graph.model(name, f"linear damper F = {damping:g} N.s/m * v", [("velocity", 1)], [("force", 1)])
    low, high = velocity_range if velocity_range is not None else (None, None)
    Component(
        name=name,
        inputs=[Port("velocity", "m/s", min=low, max=high)],
        outputs=[Port("force", "N")],
        sample_period=sample_period,
        description="linear damper",
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model
