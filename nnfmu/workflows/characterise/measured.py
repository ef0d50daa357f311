"""The standard tests read from a measurement: its sine tests found (`detect`), each read as the model's are, and the
test points the model is then run at (the same amplitude, frequency and command)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.data.measurement import Measurement
from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.workflows.characterise.analysis import (
    DamperPoint,
    GasAndFriction,
    StiffnessPoint,
    damper_point,
    gas_and_friction,
    stiffness_point,
)
from nnfmu.workflows.characterise.detect import HYSTERESIS, MIN_CYCLES, SineSegment, find_sine_tests
from nnfmu.workflows.characterise.kind import BushingPorts, CharacteriseError, DamperPorts
from nnfmu.workflows.characterise.signals import SineTest

# A segment's command must stay within this fraction of the record's command span to count as one level.
COMMAND_SPREAD = 0.02


@dataclass(frozen=True)
class Cycle:
    """One measured cycle (the segment's last): position, rate and force."""

    position: np.ndarray
    rate: np.ndarray
    force: np.ndarray


@dataclass(frozen=True)
class MeasuredDamper:
    """The record's characteristic points, their tests (for the model), work-diagram cycles, gas force and friction
    per command level, and the segments left out (with why)."""

    points: list[DamperPoint]
    tests: list[SineTest]
    cycles: list[Cycle]
    gas_friction: dict[float | None, GasAndFriction]
    skipped: list[str]


@dataclass(frozen=True)
class MeasuredBushing:
    """Per channel key the record's stiffness points, their tests (for the model) and the slowest test's cycle."""

    points: dict[str, list[StiffnessPoint]]
    tests: dict[str, list[SineTest]]
    loops: dict[str, tuple[SineTest, Cycle]]


def _channel(record: Measurement, name: str, why: str) -> np.ndarray:
    if name not in record:
        raise CharacteriseError(
            f"{record.source}: no channel {name!r} ({why}); the record has: {', '.join(record.names)}"
        )
    return np.asarray(record[name], dtype=float)


def _segments(record: Measurement, position: str) -> list[SineSegment]:
    found = find_sine_tests(record.time, _channel(record, position, "the sine tests' position"))
    if not found:
        raise CharacteriseError(
            f"{record.source}: no sine test found in {position!r} (at least {MIN_CYCLES} consecutive cycles of one "
            f"period and amplitude, crossings counted with {HYSTERESIS:.0%} hysteresis; docs/characterise.md)"
        )
    return found


def _last_cycle(record: Measurement, segment: SineSegment, position: np.ndarray, rate: np.ndarray, force) -> Cycle:
    n = int(round(1 / (segment.frequency * record.sample_period)))
    part = slice(max(segment.start, segment.stop - n - 1), segment.stop)
    return Cycle(position[part], rate[part], force[part])


def _rate(record: Measurement, name: str, position: np.ndarray) -> np.ndarray:
    """The recorded rate channel, else the position's derivative."""
    return np.asarray(record[name], dtype=float) if name in record else np.gradient(position, record.time)


def measured_damper(record: Measurement, ports: DamperPorts, settle_cycles: int) -> MeasuredDamper:
    """The characteristic of `record`'s sine tests (channels `displacement`, `force`, and the model's command)."""
    x = _channel(record, "displacement", "the damper's stroke")
    force = _channel(record, "force", "the damper's force")
    v = _rate(record, "velocity", x)
    command = _channel(record, ports.command, "the model's command input") if ports.command else None
    span = float(np.ptp(command)) if command is not None else 0.0
    points, tests, cycles, skipped = [], [], [], []
    slowest: dict[float | None, tuple[SineSegment, float]] = {}
    for seg in _segments(record, "displacement"):
        part = slice(seg.start, seg.stop)
        level = None
        if command is not None:
            if np.ptp(command[part]) > COMMAND_SPREAD * span:
                skipped.append(
                    f"{record.time[seg.start]:.3f}-{record.time[seg.stop - 1]:.3f} s: {ports.command} varies "
                    f"over the test ({np.ptp(command[part]):.3g} {ports.command_unit})"
                )
                continue
            level = float(np.mean(command[part]))
        points.append(damper_point(record.time[part], x[part], force[part], seg.frequency, level))
        tests.append(SineTest(seg.amplitude, seg.frequency, settle_cycles, level))
        cycles.append(_last_cycle(record, seg, x, v, force))
        if level not in slowest or points[-1].peak_velocity < slowest[level][1]:
            slowest[level] = (seg, points[-1].peak_velocity)
    if not points:
        raise CharacteriseError(f"{record.source}: no sine test at a constant command ({'; '.join(skipped)})")
    order = sorted(range(len(points)), key=lambda i: (points[i].command or 0.0, points[i].peak_velocity))
    points, tests, cycles = [points[i] for i in order], [tests[i] for i in order], [cycles[i] for i in order]
    gas = {
        level: gas_and_friction(
            record.time[s.start : s.stop], x[s.start : s.stop], force[s.start : s.stop], s.frequency
        )
        for level, (s, _v) in slowest.items()
    }
    return MeasuredDamper(points, tests, cycles, gas, skipped)


def measured_bushing(record: Measurement, ports: BushingPorts, settle_cycles: int) -> MeasuredBushing:
    """Each channel's dynamic stiffness from `record`'s sine tests of its position and force channels."""
    points, tests, loops = {}, {}, {}
    for ch in ports.channels:
        x = _channel(record, ch.position, f"channel {ch.key}'s position")
        force = _channel(record, ch.force, f"channel {ch.key}'s force")
        segments = _segments(record, ch.position)
        points[ch.key] = [
            stiffness_point(
                ch.key, record.time[s.start : s.stop], x[s.start : s.stop], force[s.start : s.stop], s.frequency
            )
            for s in segments
        ]
        tests[ch.key] = [SineTest(s.amplitude, s.frequency, settle_cycles) for s in segments]
        slow = min(segments, key=lambda s: (s.frequency, -s.amplitude))
        loops[ch.key] = (
            SineTest(slow.amplitude, slow.frequency, settle_cycles),
            _last_cycle(record, slow, x, _rate(record, BUSHING_CHANNELS[ch.key].rate, x), force),
        )
    return MeasuredBushing(points, tests, loops)
