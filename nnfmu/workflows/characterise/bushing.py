"""The bushing's standard tests on a model, per channel (the others held at rest): dynamic stiffness and loss angle
over the frequency x amplitude grid, and the quasi-static force-deflection loop."""

from __future__ import annotations

from dataclasses import dataclass

from nnfmu.workflows.characterise.analysis import StiffnessPoint, stiffness_point
from nnfmu.workflows.characterise.kind import BushingChannelPorts, BushingPorts, CharacteriseError
from nnfmu.workflows.characterise.model import ModelUnderTest, TestRun, run_test
from nnfmu.workflows.characterise.settings import VEHICLE_RANGE, BushingTestSettings
from nnfmu.workflows.characterise.signals import SineTest, check_tests


@dataclass(frozen=True)
class ChannelPlan:
    """The tests of one channel: the dynamic-stiffness points and the quasi-static loop."""

    channel: BushingChannelPorts
    stiffness: list[SineTest]
    loop: SineTest


@dataclass(frozen=True)
class BushingResult:
    """Per channel key its stiffness points (in test order) and its quasi-static loop run."""

    channels: tuple[BushingChannelPorts, ...]
    points: dict[str, list[StiffnessPoint]]
    loops: dict[str, TestRun]


def channel_plan(channel: BushingChannelPorts, settings: BushingTestSettings) -> ChannelPlan:
    """The default grid: every frequency at every amplitude fraction of the channel's vehicle range."""
    reach = VEHICLE_RANGE[channel.key]
    tests = [
        SineTest(fraction * reach, f, settings.settle_cycles)
        for fraction in settings.amplitude_fractions
        for f in settings.frequencies
    ]
    loop = SineTest(max(settings.amplitude_fractions) * reach, settings.quasi_static_frequency, 1)
    return ChannelPlan(channel, tests, loop)


def channel_inputs(ports: BushingPorts, channel: BushingChannelPorts) -> dict[str, tuple[str, str]]:
    """Every input of the model: `channel`'s position and rate move, every other channel rests."""
    inputs = {}
    for other in ports.channels:
        moving = other.key == channel.key
        inputs[other.position] = ("position" if moving else "zero", other.position_unit)
        if other.rate:
            inputs[other.rate] = ("rate" if moving else "zero", f"{other.position_unit}/s")
    return inputs


def read_channel(channel: str, runs: list[TestRun]) -> list[StiffnessPoint]:
    """The dynamic stiffness of each run, read on its measured cycle."""
    points = []
    for run in runs:
        time, position, _rate, force = run.cycle()
        points.append(stiffness_point(channel, time, position, force, run.test.frequency))
    return points


def characterise_bushing(model: ModelUnderTest, plans: list[ChannelPlan]) -> BushingResult:
    """Run every channel's plan through the model's FMU and read it."""
    ports = model.kind
    if not isinstance(ports, BushingPorts):
        raise CharacteriseError(f"{model.source}: not a bushing")
    check_tests([t for p in plans for t in (*p.stiffness, p.loop)], model.period, f"{model.source}: bushing tests")
    points, loops = {}, {}
    for plan in plans:
        inputs = channel_inputs(ports, plan.channel)
        runs = [run_test(model, test, inputs, plan.channel.force) for test in plan.stiffness]
        points[plan.channel.key] = read_channel(plan.channel.key, runs)
        loops[plan.channel.key] = run_test(model, plan.loop, inputs, plan.channel.force)
    return BushingResult(tuple(p.channel for p in plans), points, loops)
