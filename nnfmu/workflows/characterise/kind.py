"""Which standard test a model takes, read from its `Component`: the one place a damper or bushing is recognised.

A damper has the output `force` [N] and the input `velocity` [m/s], and may take `displacement` [m] (gas spring,
accumulator), a command (`voltage` [V] or `current` [A]: a semi-active damper, tested per command level) and
`temperature` [K] (held at the test temperature). A bushing has one or more of the rig's channel outputs
(`axial_force` [N], `radial_force` [N], `axial_torque` [N.m], `conical_torque` [N.m]), each with its position input
and optionally its rate input, and nothing else. Names and units are the rigs' (`nnfmu.data.rigs`), which training
carries into the component's ports.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from nnfmu.component import Component, Port
from nnfmu.data.rigs import BUSHING_CHANNELS, COMMAND_CHANNELS
from nnfmu.data.rigs.damper_rig import UNITS as DAMPER_UNITS
from nnfmu.data.rigs.semiactive_rig import UNITS as SEMIACTIVE_UNITS
from nnfmu.errors import NnfmuError
from nnfmu.kinds import BUSHING, DAMPER

DAMPER_INPUTS = ("velocity", "displacement", "temperature", *COMMAND_CHANNELS.values())


class CharacteriseError(NnfmuError, ValueError):
    """A model or record the standard tests cannot run on; the message names the file, port or channel."""


@dataclass(frozen=True)
class DamperPorts:
    """A damper's ports: which optional inputs it takes; `command` is `voltage` or `current` for a semi-active one."""

    displacement: bool
    temperature: bool
    command: str | None
    kind: ClassVar[str] = DAMPER.name

    @property
    def command_unit(self) -> str:
        return SEMIACTIVE_UNITS[self.command] if self.command else ""


@dataclass(frozen=True)
class BushingChannelPorts:
    """One bushing channel (a `BUSHING_CHANNELS` key) the model has: position input, optional rate input, output."""

    key: str
    position: str
    rate: str | None
    force: str
    position_unit: str
    force_unit: str

    @property
    def stiffness_unit(self) -> str:
        return f"{self.force_unit}/{self.position_unit}"


@dataclass(frozen=True)
class BushingPorts:
    """The bushing channels a model has, in the rig's order."""

    channels: tuple[BushingChannelPorts, ...]
    kind: ClassVar[str] = BUSHING.name


def _check_unit(port: Port, expected: str, source: str, side: str) -> None:
    if port.unit and port.unit != expected:
        raise CharacteriseError(
            f"{source}: {side} {port.name!r} is in {port.unit!r}, the standard test needs {expected!r}"
        )


def _listing(component: Component) -> str:
    ins = ", ".join(p.name for p in component.inputs) or "none"
    outs = ", ".join(p.name for p in component.outputs) or "none"
    return f"inputs: {ins}; outputs: {outs}"


def _damper(component: Component, source: str) -> DamperPorts:
    units = {**DAMPER_UNITS, **SEMIACTIVE_UNITS}
    names = [p.name for p in component.inputs]
    for port in component.inputs:
        if port.name not in DAMPER_INPUTS:
            raise CharacteriseError(
                f"{source}: damper input {port.name!r} is no channel the characteristic test drives "
                f"({', '.join(DAMPER_INPUTS)})"
            )
        _check_unit(port, units[port.name], source, "input")
    for port in component.outputs:
        if port.name == "force":
            _check_unit(port, "N", source, "output")
    commands = [n for n in names if n in COMMAND_CHANNELS.values()]
    if len(commands) > 1:
        raise CharacteriseError(f"{source}: a damper has one command, this one takes {' and '.join(commands)}")
    return DamperPorts("displacement" in names, "temperature" in names, commands[0] if commands else None)


def _bushing(component: Component, source: str) -> BushingPorts:
    inputs = {p.name: p for p in component.inputs}
    outputs = {p.name: p for p in component.outputs}
    channels, used = [], set()
    for key, ch in BUSHING_CHANNELS.items():
        if ch.force not in outputs:
            continue
        _check_unit(outputs[ch.force], ch.force_unit, source, "output")
        if ch.position not in inputs:
            raise CharacteriseError(
                f"{source}: bushing output {ch.force!r} has no position input {ch.position!r} ({_listing(component)})"
            )
        _check_unit(inputs[ch.position], ch.position_unit, source, "input")
        if ch.rate in inputs:
            _check_unit(inputs[ch.rate], ch.rate_unit, source, "input")
        rate = ch.rate if ch.rate in inputs else None
        used.update({ch.position, rate})
        channels.append(BushingChannelPorts(key, ch.position, rate, ch.force, ch.position_unit, ch.force_unit))
    extra = [name for name in inputs if name not in used]
    if extra:
        raise CharacteriseError(
            f"{source}: bushing input {extra[0]!r} belongs to no channel whose force or torque the model outputs "
            f"({_listing(component)})"
        )
    return BushingPorts(tuple(channels))


def component_kind(component: Component, source: str) -> DamperPorts | BushingPorts:
    """The damper or bushing test `component` takes; CharacteriseError naming `source` and the port otherwise."""
    inputs = {p.name for p in component.inputs}
    outputs = {p.name for p in component.outputs}
    if "force" in outputs and "velocity" in inputs:
        return _damper(component, source)
    if outputs & {ch.force for ch in BUSHING_CHANNELS.values()}:
        return _bushing(component, source)
    forces = ", ".join(ch.force for ch in BUSHING_CHANNELS.values())
    raise CharacteriseError(
        f"{source}: neither a damper (output 'force' [N] with input 'velocity' [m/s]) nor a bushing (outputs among "
        f"{forces}); {_listing(component)}"
    )
