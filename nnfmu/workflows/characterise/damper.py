"""The damper's characteristic test on a model: the sine series per command level, read into the characteristic
diagram, the work diagrams and the gas force and friction of the slowest test."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnfmu.component import Component
from nnfmu.workflows.characterise.analysis import DamperPoint, GasAndFriction, damper_point, gas_and_friction
from nnfmu.workflows.characterise.kind import CharacteriseError, DamperPorts
from nnfmu.workflows.characterise.model import ModelUnderTest, TestRun, run_test
from nnfmu.workflows.characterise.settings import DamperTestSettings
from nnfmu.workflows.characterise.signals import SineTest, check_tests


@dataclass(frozen=True)
class DamperResult:
    """Every test run, its characteristic point (same order), and the gas force and friction per command level
    (key None for a passive damper), read from that level's slowest test."""

    runs: list[TestRun]
    points: list[DamperPoint]
    gas_friction: dict[float | None, GasAndFriction]


def command_levels(settings: DamperTestSettings, ports: DamperPorts, component: Component, source: str) -> list:
    """The command levels to test: None alone for a passive damper; the given ones, else `command_levels` levels
    evenly across the command input's training envelope (CharacteriseError naming the port when it has none)."""
    if ports.command is None:
        return [None]
    if settings.commands is not None:
        return list(settings.commands)
    port = next(p for p in component.inputs if p.name == ports.command)
    if port.min is None or port.max is None:
        raise CharacteriseError(
            f"{source}: the command input {port.name!r} records no training envelope; give the levels to test "
            f"({port.name} [{ports.command_unit}], --commands)"
        )
    return [float(c) for c in np.linspace(port.min, port.max, settings.command_levels)]


def damper_tests(settings: DamperTestSettings, levels: list) -> list[SineTest]:
    """The sine series at the fixed stroke, slowest first, per command level."""
    return [
        SineTest(settings.stroke, v / (2 * math.pi * settings.stroke), settings.settle_cycles, level)
        for level in levels
        for v in settings.peak_velocities
    ]


def damper_inputs(ports: DamperPorts, temperature: float) -> dict[str, tuple[str, str]]:
    """What drives each of the damper's inputs in a test: (signal or held value, unit)."""
    inputs = {"velocity": ("rate", "m/s")}
    if ports.displacement:
        inputs["displacement"] = ("position", "m")
    if ports.temperature:
        inputs["temperature"] = (repr(temperature), "K")
    if ports.command:
        inputs[ports.command] = ("command", ports.command_unit)
    return inputs


def read_damper(runs: list[TestRun]) -> DamperResult:
    """The characteristic points of `runs` (each read on its measured cycle) and gas force and friction from each
    command level's slowest run."""
    points = []
    slowest: dict[float | None, TestRun] = {}
    for run in runs:
        time, position, _rate, force = run.cycle()
        points.append(damper_point(time, position, force, run.test.frequency, run.test.command))
        level = run.test.command
        if level not in slowest or run.test.peak_rate < slowest[level].test.peak_rate:
            slowest[level] = run
    found = {}
    for level, run in slowest.items():
        time, position, _rate, force = run.cycle()
        found[level] = gas_and_friction(time, position, force, run.test.frequency)
    return DamperResult(runs, points, found)


def characterise_damper(model: ModelUnderTest, tests: list[SineTest], temperature: float) -> DamperResult:
    """Run `tests` through the model's FMU and read them."""
    if not isinstance(model.kind, DamperPorts):
        raise CharacteriseError(f"{model.source}: not a damper")
    check_tests(tests, model.period, f"{model.source}: damper characteristic test")
    inputs = damper_inputs(model.kind, temperature)
    return read_damper([run_test(model, test, inputs, "force") for test in tests])
