"""The passive baseline of a closed loop: a controller with the skyhook controller's ports that holds one command.

Put in the skyhook controller's place, it runs the same semi-active damper at a fixed setting (soft, hard or between)
on the same system, so the two are compared with nothing else changed.
"""

from __future__ import annotations

import math

import numpy as np
import onnx

from nnfmu.component import SAMPLE_PERIOD_RANGE
from nnfmu.control.command import SENSOR_PORTS, Command, controller_component
from nnfmu.errors import SettingsError
from nnfmu.export.graph import GraphBuilder

DEFAULT_SAMPLE_PERIOD = 1e-3  # [s]: the skyhook controller's


def fixed_command_graph(
    command: Command, value: float, sample_period: float = DEFAULT_SAMPLE_PERIOD, name: str = "fixed_command"
) -> onnx.ModelProto:
    """Step graph `body_velocity`, `damper_velocity` [m/s] (read, not used) -> `command.name` = `value` in
    command.unit, every `sample_period` [s]; SettingsError naming the value when either is out of range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SettingsError(f"fixed command {command.name} {value!r} {command.unit} must be a finite number")
    low, high = SAMPLE_PERIOD_RANGE
    number = isinstance(sample_period, (int, float)) and not isinstance(sample_period, bool)
    if not number or not low <= sample_period <= high:
        raise SettingsError(
            f"fixed command sample_period {sample_period!r} s must be a number from {low:g} to {high:g} s"
        )
    g = GraphBuilder(reserved=(*SENSOR_PORTS, command.name))
    g.output(g.constant("held_command", np.array([float(value)])), command.name)
    doc = f"fixed damper command {command.name} = {value:g} {command.unit}"
    model = g.model(name, doc, [(port, 1) for port in SENSOR_PORTS], [(command.name, 1)])
    controller_component(
        name,
        command,
        "semi-active damper command, held fixed",
        sample_period,
        doc,
        {"controller": "fixed", "value": float(value)},
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model
