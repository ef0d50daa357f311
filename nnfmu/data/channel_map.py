"""Channel names as files write them: the same channel written twice, and the user's explicit renaming (`--map`).

Two names are the same channel when they agree ignoring case, surrounding space and space-versus-underscore
(`force` and `Force`, `Axial Force` and `axial_force`); a file naming one channel twice is refused with both columns
named. A channel map renames file channels to nnfmu's names: `{"Axial Force": "force"}`, on the command line
`--map "Axial Force=force"`; its keys are matched the same way, its targets must be plain names (`[a-z][a-z0-9_]*`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence

from nnfmu.data.errors import DataError
from nnfmu.data.raw import RawTable
from nnfmu.errors import SettingsError

_SAME = re.compile(r"[\s_]+")
_TARGET = re.compile(r"^[a-z][a-z0-9_]*$")


def channel_key(name: str) -> str:
    """The form in which two channel names are compared: `' Axial  Force'` -> `'axial_force'`."""
    return _SAME.sub("_", name.strip().casefold())


def first_duplicate(names: Sequence[str]) -> tuple[int, int] | None:
    """Positions (earlier, later) of the first name that repeats an earlier one as the same channel, else None."""
    seen: dict[str, int] = {}
    for position, name in enumerate(names):
        key = channel_key(name)
        if key in seen:
            return seen[key], position
        seen[key] = position
    return None


def parse_channel_map(items: Iterable[str]) -> dict[str, str]:
    """`'FILE CHANNEL=name'` items (from `--map`) as {file channel: nnfmu name}; SettingsError for a malformed item."""
    mapping: dict[str, str] = {}
    for item in items:
        source, equals, target = item.rpartition("=")
        if not equals or not source.strip() or not target.strip():
            raise SettingsError(f"channel map {item!r}: write it as 'FILE CHANNEL=name', e.g. 'Axial Force=force'")
        mapping[source.strip()] = target.strip()
    return mapping


def resolve_channel_map(mapping: Mapping[str, str], names: Sequence[str], where: str) -> dict[int, str]:
    """{position in `names`: nnfmu name} for each entry of `mapping`; DataError naming `where` for a key the file
    lacks, a target that is not a plain name, or two entries for one channel or onto one name."""
    keys = [channel_key(name) for name in names]
    resolved: dict[int, str] = {}
    for source, target in mapping.items():
        if not _TARGET.match(target):
            raise DataError(
                f"{where}: channel map {source!r} -> {target!r}: the new name must be lower case letters, digits and "
                f"'_', starting with a letter (e.g. 'force', 'axial_displacement')"
            )
        if channel_key(source) not in keys:
            raise DataError(
                f"{where}: channel map names {source!r}, which the file does not have; its channels are "
                f"{', '.join(map(repr, names))}"
            )
        position = keys.index(channel_key(source))
        if position in resolved:
            raise DataError(f"{where}: channel map names {names[position]!r} twice")
        if target in resolved.values():
            raise DataError(f"{where}: channel map maps two channels onto {target!r}")
        resolved[position] = target
    return resolved


def rename_channels(raw: RawTable, mapping: Mapping[str, str], where: str) -> RawTable:
    """`raw` with its channels renamed by `mapping` (see `resolve_channel_map`), and `notes["channels"]` saying so.

    The time axis is the file's own time column and cannot be mapped; DataError if a new name repeats another
    channel.
    """
    names = list(raw.channels)
    resolved = resolve_channel_map(mapping, names, where)
    if "time" in resolved.values():
        raise DataError(f"{where}: the time axis is the file's time column; a channel map cannot name another 'time'")
    renamed = [resolved.get(position, name) for position, name in enumerate(names)]
    clash = first_duplicate(renamed)
    if clash is not None:
        a, b = clash
        raise DataError(
            f"{where}: after the channel map, {names[a]!r} and {names[b]!r} would both be channel {renamed[b]!r}"
        )
    done = ", ".join(f"{names[position]!r} -> {target}" for position, target in resolved.items())
    return RawTable(
        time=raw.time,
        time_unit=raw.time_unit,
        channels={new: raw.channels[old] for old, new in zip(names, renamed)},
        units={new: raw.units[old] for old, new in zip(names, renamed)},
        time_resolution=raw.time_resolution,
        notes={**raw.notes, "channels": f"channels renamed by the channel map: {done}"},
    )
