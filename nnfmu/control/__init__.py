"""Controllers of semi-active dampers as nnfmu step graphs: the skyhook law and a fixed-command baseline, each with
the vehicle's sensor ports (`body_velocity`, `damper_velocity`) and the damper's command port (`voltage` [V] for an
MR damper, `current` [A] for a CDC damper)."""

from nnfmu.control.command import KNOWN_COMMANDS, SENSOR_PORTS, Command, known_command
from nnfmu.control.fixed import fixed_command_graph
from nnfmu.control.skyhook import SkyhookSettings, skyhook_graph

__all__ = [
    "KNOWN_COMMANDS",
    "SENSOR_PORTS",
    "Command",
    "SkyhookSettings",
    "fixed_command_graph",
    "known_command",
    "skyhook_graph",
]
