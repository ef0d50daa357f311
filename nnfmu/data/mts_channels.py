"""MTS 793 / TestSuite channel names (`Axial Displacement`, `Axial Force`, `Running Time`) as nnfmu channel names.

A name is read in lower case with every run of other characters as `_` (`Axial Displacement` -> `axial_displacement`).
Its last word (or two: `angular velocity`) is the signal, named as nnfmu names it through SIGNALS (`stroke`,
`position` -> displacement; `load` -> force; `angle` -> rotation; ...); the words before are the axis (`axial`).
- The time axis is the one channel whose signal is `time` and whose unit is a time; of several, `Running Time`.
- A signal channel is named after its signal alone when no other channel of the file has that signal
  (`Axial Force` -> `force`), else axis and signal (`Axial Force`, `Radial Force` -> `axial_force`, `radial_force`).
- Any other channel keeps its lower-case name (`Axial Command` -> `axial_command`, converted by its unit), or is left
  out, with a note, when nnfmu knows neither its name nor its unit (`Axial Count [cycles]`) or when it is a second
  time channel.
An explicit channel map (`{"Load Cell": "force"}`; `--map "Load Cell=force"`) names channels before these rules and
wins over them; mapping a channel to `time` makes it the time axis. Two channels ending on one name are refused,
naming both columns.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from nnfmu.data.channel_map import first_duplicate, resolve_channel_map
from nnfmu.data.errors import DataError
from nnfmu.data.units import QUANTITIES, unit_quantities

SIGNALS: dict[str, str] = {
    "displacement": "displacement",
    "stroke": "displacement",
    "position": "displacement",
    "force": "force",
    "load": "force",
    "velocity": "velocity",
    "acceleration": "acceleration",
    "angular_velocity": "angular_velocity",
    "angular_acceleration": "angular_acceleration",
    "rotation": "rotation",
    "angle": "rotation",
    "torque": "torque",
    "temperature": "temperature",
    "pressure": "pressure",
    "time": "time",
}
PREFERRED_TIME = "running_time"

_OTHER = re.compile(r"[^0-9a-z]+")


def snake_name(name: str) -> str:
    """`'Axial Displacement'` -> `'axial_displacement'`; `''` when the name has no letter or digit."""
    return _OTHER.sub("_", name.casefold()).strip("_")


def _signal(snake: str) -> tuple[str, str] | None:
    """(axis words, nnfmu signal) of a lower-case name, e.g. ('axial', 'displacement'); None without a signal."""
    words = snake.split("_")
    for count in (2, 1):
        tail = "_".join(words[-count:])
        if len(words) >= count and tail in SIGNALS:
            return "_".join(words[:-count]), SIGNALS[tail]
    return None


@dataclass(frozen=True)
class ChannelPlan:
    """Which file column is the time axis, which become which nnfmu channel, which are left out and why."""

    time: int
    names: dict[int, str]
    left_out: dict[int, str]

    def describe(self, names: Sequence[str], units: Sequence[str]) -> str:
        """One line: every file channel and what became of it."""
        read = [f"{names[self.time]!r} [{units[self.time]}] -> time"]
        read += [f"{names[c]!r} [{units[c]}] -> {target}" for c, target in self.names.items()]
        text = "channels read as " + ", ".join(read)
        if self.left_out:
            text += "; left out: " + ", ".join(f"{names[c]!r} [{units[c]}] ({why})" for c, why in self.left_out.items())
        return text


def _signal_of(name: str) -> str | None:
    found = _signal(snake_name(name))
    return None if found is None else found[1]


def _is_time_unit(unit: str) -> bool:
    return QUANTITIES["time"] in unit_quantities(unit)


def _time_column(names: Sequence[str], units: Sequence[str], explicit: dict[int, str], where: str) -> int:
    chosen = [column for column, target in explicit.items() if target == "time"]
    if chosen:
        return chosen[0]
    candidates = [
        c
        for c, name in enumerate(names)
        if c not in explicit and _signal_of(name) == "time" and _is_time_unit(units[c])
    ]
    preferred = [c for c in candidates if snake_name(names[c]) == PREFERRED_TIME]
    if len(candidates) == 1 or preferred:
        return (preferred or candidates)[0]
    listing = ", ".join(f"{name!r} [{unit}]" for name, unit in zip(names, units))
    if not candidates:
        raise DataError(f"{where}: no time channel among {listing}; name one with a channel map, e.g. 'NAME=time'")
    raise DataError(
        f"{where}: several time channels ({', '.join(repr(names[c]) for c in candidates)}); choose one with a "
        f"channel map, e.g. '{names[candidates[0]]}=time'"
    )


def plan_channels(
    names: Sequence[str], units: Sequence[str], mapping: Mapping[str, str] | None, where: str
) -> ChannelPlan:
    """Apply the rules of the module docstring to the file's channel `names` and `units` (unit text as in the file,
    MTS spellings already translated); DataError naming `where` and the columns at fault."""
    explicit = resolve_channel_map(mapping or {}, names, where)
    time = _time_column(names, units, explicit, where)
    signals = {c: _signal(snake_name(name)) for c, name in enumerate(names) if c not in explicit and c != time}
    counts: dict[str, int] = {}
    for found in signals.values():
        if found is not None:
            counts[found[1]] = counts.get(found[1], 0) + 1
    chosen: dict[int, str] = {c: target for c, target in explicit.items() if c != time}
    left_out: dict[int, str] = {}
    for column, found in signals.items():
        snake = snake_name(names[column])
        if found is not None and found[1] == "time":
            left_out[column] = "a second time channel"
        elif found is not None:
            axis, signal = found
            target = signal if counts[signal] == 1 or not axis else f"{axis}_{signal}"
            chosen[column] = snake if target in explicit.values() else target
        elif not snake:
            raise DataError(f"{where}: column {column + 1} has no channel name")
        elif not unit_quantities(units[column]):
            left_out[column] = "a unit nnfmu does not know"
        else:
            chosen[column] = snake
    order = sorted(chosen)
    clash = first_duplicate([chosen[c] for c in order])
    if clash is not None:
        a, b = order[clash[0]], order[clash[1]]
        raise DataError(
            f"{where}: columns {a + 1} {names[a]!r} and {b + 1} {names[b]!r} would both be channel {chosen[a]!r}; "
            f"say which is which with a channel map, e.g. '{names[a]}={chosen[a]}'"
        )
    return ChannelPlan(time=time, names={c: chosen[c] for c in order}, left_out=left_out)
