"""CSV rig files: a header of `name [unit]` cells with `time [s]` first, then one row of numbers per sample.

Accepted header cells: `name [unit]`, `name[unit]` or `name (unit)`, with any whitespace around; a cell without a
unit is an error. The delimiter is `,`, or `;` or a tab when the header contains no comma; a UTF-8 byte order
mark (as Excel writes it) is ignored. Two columns naming the same channel (`force [N]`, `Force [kN]`: see
`channel_map.channel_key`) are refused, and so is a header line longer than MAX_HEADER_CHARS, before the rest of the
file is read. The time column's text tells how finely the stamps were printed (`timebase.printed_resolution`).
Written files use `,`, `name [unit]` and each value's shortest repr, which reads back to the identical float64.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np

from nnfmu.data.channel_map import first_duplicate
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.raw import RawTable
from nnfmu.data.timebase import printed_resolution

MAX_HEADER_CHARS = 65536  # a header of 1000 channels with 64-character names fits

_BRACKETS = (("[", "]"), ("(", ")"))
_FORBIDDEN_IN_NAME = re.compile(r"[\[\](),;\t\r\n]")


def _delimiter(header: str) -> str:
    for candidate in (",", ";", "\t"):
        if candidate in header:
            return candidate
    return ","


def _split_unit(cell: str) -> tuple[str, str] | None:
    """`'force [kN]'` -> ('force', 'kN'): the unit is the last bracketed part, which must end the cell; else None.

    Linear in the cell's length (a backtracking pattern took minutes on a long cell of spaces).
    """
    for opening, closing in _BRACKETS:
        if cell.endswith(closing):
            inner = cell[:-1]
            start = inner.find(opening, inner.rfind(closing) + 1)
            if start >= 0:
                return inner[:start].rstrip(), inner[start + 1 :]
    return None


def _parse_header_cell(cell: str, column: int, path: Path) -> tuple[str, str]:
    split = _split_unit(cell.strip())
    if split is not None and not split[0]:
        raise DataError(f"{path}: header column {column + 1} {cell.strip()!r} has no channel name")
    if split is None:
        raise DataError(
            f"{path}: header column {column + 1} {cell.strip()!r} has no unit; write it as 'name [unit]', "
            f"e.g. 'force [N]'"
        )
    unit = split[1].strip()
    if not unit:
        raise DataError(f"{path}: header column {column + 1} {cell.strip()!r} has an empty unit")
    return split[0], unit


def _diagnose_rows(lines: list[str], delimiter: str, header: list[str], path: Path, reason: str) -> DataError:
    """The error for the first data line that does not parse (numbers as in the file, line 1 = the header)."""
    for offset, line in enumerate(lines):
        try:
            cells = next(csv.reader([line], delimiter=delimiter), [])
        except csv.Error as error:
            return DataError(f"{path}: line {offset + 2} cannot be split into cells: {error}")
        line = offset + 2
        if not cells:
            continue
        if len(cells) != len(header):
            return DataError(f"{path}: line {line} has {len(cells)} cells, the header {len(header)}")
        for cell, column in zip(cells, header):
            try:
                float(cell)
            except ValueError:
                return DataError(f"{path}: line {line}, column {column.strip()!r}: {cell!r} is not a number")
    return DataError(f"{path}: cannot read the data rows: {reason}")


def _read_text(path: Path) -> tuple[str, str]:
    """(header line, rest of the file) as UTF-8 text; DataError for an unreadable file or an overlong header line."""
    try:
        with path.open(encoding="utf-8-sig", newline="") as stream:
            header_line = stream.readline(MAX_HEADER_CHARS + 1)
            if len(header_line) > MAX_HEADER_CHARS:
                raise DataError(
                    f"{path}: the header line is longer than {MAX_HEADER_CHARS} characters; expected a header like "
                    f"'time [s],displacement [m],force [N]'"
                )
            body = stream.read()
    except (OSError, UnicodeDecodeError) as error:
        raise DataError(f"{path}: cannot read as UTF-8 text: {error}") from None
    return header_line.rstrip("\r\n"), body


def _refuse_duplicates(names: list[str], header: list[str], path: Path) -> None:
    clash = first_duplicate(names)
    if clash is not None:
        a, b = clash
        raise DataError(
            f"{path}: column(s) {names[a]!r} appear more than once: column {a + 1} {header[a].strip()!r} and column "
            f"{b + 1} {header[b].strip()!r} name the same channel (names are compared ignoring case); keep one"
        )


def read_csv(path: Path) -> RawTable:
    """Read a CSV rig file as stored (units not converted); raise DataError naming the line or column at fault."""
    header_line, body = _read_text(path)
    if not header_line.strip():
        raise DataError(f"{path}: empty file, expected a header like 'time [s],displacement [m],force [N]'")
    delimiter = _delimiter(header_line)
    header = next(csv.reader([header_line], delimiter=delimiter))
    columns = [_parse_header_cell(cell, i, path) for i, cell in enumerate(header)]
    names = [name for name, _ in columns]
    if names[0].lower() != "time":
        raise DataError(f"{path}: the first column must be 'time [s]', found {header[0].strip()!r}")
    if len(names) < 2:
        raise DataError(f"{path}: no channels besides time")
    _refuse_duplicates(names, header, path)
    lines = [line for line in body.splitlines() if line.strip()]
    if lines:
        try:
            data = np.loadtxt(lines, delimiter=delimiter, ndmin=2, dtype=np.float64)
        except ValueError as error:
            raise _diagnose_rows(lines, delimiter, header, path, str(error)) from None
    else:
        data = np.empty((0, len(columns)))
    if data.shape[1] != len(columns):
        raise _diagnose_rows(lines, delimiter, header, path, f"{data.shape[1]} values per row")
    time_cells = [line.split(delimiter, 1)[0] for line in lines]
    return RawTable(
        time=data[:, 0].copy(),
        time_unit=columns[0][1],
        channels={name: data[:, i].copy() for i, (name, _) in enumerate(columns[1:], start=1)},
        units={name: unit for name, unit in columns[1:]},
        time_resolution=printed_resolution(time_cells, data[:, 0]),
    )


def write_csv(m: Measurement, path: Path) -> None:
    """Write `m` as CSV to `path` (exactly there; atomicity is the caller's job) with exact float64 values."""
    for name in m.channels:
        if _FORBIDDEN_IN_NAME.search(name) or not name.strip():
            raise DataError(f"{m.source}: channel name {name!r} cannot be written as a CSV header cell")
    header = ",".join(["time [s]", *(f"{name} [{m.units[name]}]" for name in m.channels)])
    table = np.column_stack([m.time, *m.channels.values()]).astype(np.float64).tolist()
    with path.open("w", encoding="utf-8", newline="\n") as stream:
        stream.write(header + "\n")
        for row in table:
            stream.write(",".join(map(repr, row)) + "\n")
