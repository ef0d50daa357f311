"""The command a semi-active damper takes, named after its channel: an MR damper's coil `voltage` [V] or a CDC
damper's valve `current` [A], with the working range of each (those of issue 19's MR and CDC rig simulators); and
the component description every controller shares (the vehicle's sensor ports in, the command out)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from nnfmu.component import Component, Port
from nnfmu.errors import SettingsError

# name -> (unit, (softest, hardest) command): MR coil 0-5 V (a lab amplifier's drive), CDC valve 0.3-1.8 A (ZF Sachs
# CDC, Tenneco CVSA data sheets); in both more command is harder.
KNOWN_COMMANDS = {"voltage": ("V", (0.0, 5.0)), "current": ("A", (0.3, 1.8))}
SENSOR_PORTS = ("body_velocity", "damper_velocity")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@dataclass(frozen=True)
class Command:
    """A controller's output port: channel `name`, `unit`, and the commands `soft` and `hard` that give the damper's
    least and greatest damping (`soft` > `hard` for a valve that softens with more current)."""

    name: str
    unit: str
    soft: float
    hard: float

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.fullmatch(self.name) or self.name in SENSOR_PORTS:
            raise SettingsError(
                f"command name {self.name!r} must be a plain identifier (letters, digits, _) other "
                f"than the controller's inputs {', '.join(SENSOR_PORTS)}"
            )
        if not isinstance(self.unit, str) or not self.unit.strip():
            raise SettingsError(f"command {self.name!r}: the unit {self.unit!r} must be named (V, A, ...)")
        for what, value in (("soft", self.soft), ("hard", self.hard)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise SettingsError(
                    f"command {self.name!r}: the {what} command {value!r} {self.unit} must be a finite number"
                )
        if self.soft == self.hard:
            raise SettingsError(
                f"command {self.name!r}: soft and hard command are both {self.soft!r} {self.unit}; they must differ"
            )


def known_command(name: str, soft: float | None = None, hard: float | None = None) -> Command:
    """The command `name` ('voltage' or 'current') with its unit, over its working range unless `soft` or `hard`
    are given; SettingsError naming the name when it is neither."""
    if name not in KNOWN_COMMANDS:
        raise SettingsError(f"unknown damper command {name!r}; use {' or '.join(KNOWN_COMMANDS)}")
    unit, (low, high) = KNOWN_COMMANDS[name]
    return Command(name, unit, low if soft is None else soft, high if hard is None else hard)


def controller_component(
    name: str, command: Command, what: str, sample_period: float, description: str, metadata: dict[str, Any]
) -> Component:
    """The component of a damper controller: the two sensor inputs (the vehicle's sign convention) and the command
    output, sampled every `sample_period` [s], stateless."""
    body, stroke = SENSOR_PORTS
    return Component(
        name=name,
        inputs=[
            Port(body, "m/s", "absolute vertical velocity of the sprung mass, up positive"),
            Port(stroke, "m/s", "damper stroke velocity, rebound (extension) positive"),
        ],
        outputs=[Port(command.name, command.unit, what)],
        sample_period=sample_period,
        description=description,
        metadata=metadata,
    )
