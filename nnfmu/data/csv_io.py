"""CSV rig files: a header of `name [unit]` cells with `time [s]` first, then one row of numbers per sample.

Accepted header cells: `name [unit]`, `name[unit]` or `name (unit)`, with any whitespace around; a cell without a
unit is an error. The delimiter is `,`, or `;` or a tab when the header contains no comma; a UTF-8 byte order
mark (as Excel writes it) is ignored. Written files use `,`, `name [unit]` and each value's shortest repr, which
reads back to the identical float64.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np

from .errors import DataError
from .measurement import Measurement
from .raw import RawTable

_HEADER_CELL = re.compile(r"^(?P<name>.*?)\s*(?:\[(?P<bracket>[^\]]*)\]|\((?P<paren>[^)]*)\))$")
_FORBIDDEN_IN_NAME = re.compile(r"[\[\](),;\t\r\n]")


def _delimiter(header: str) -> str:
    for candidate in (",", ";", "\t"):
        if candidate in header:
            return candidate
    return ","


def _parse_header_cell(cell: str, column: int, path: Path) -> tuple[str, str]:
    match = _HEADER_CELL.match(cell.strip())
    if match is not None and not match["name"]:
        raise DataError(f"{path}: header column {column + 1} {cell.strip()!r} has no channel name")
    if match is None:
        raise DataError(
            f"{path}: header column {column + 1} {cell.strip()!r} has no unit; write it as 'name [unit]', "
            f"e.g. 'force [N]'"
        )
    unit = (match["bracket"] if match["bracket"] is not None else match["paren"]).strip()
    if not unit:
        raise DataError(f"{path}: header column {column + 1} {cell.strip()!r} has an empty unit")
    return match["name"], unit


def _diagnose_rows(lines: list[str], delimiter: str, header: list[str], path: Path, reason: str) -> DataError:
    """The error for the first data line that does not parse (numbers as in the file, line 1 = the header)."""
    for offset, cells in enumerate(csv.reader(lines, delimiter=delimiter)):
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


def read_csv(path: Path) -> RawTable:
    """Read a CSV rig file as stored (units not converted); raise DataError naming the line or column at fault."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise DataError(f"{path}: cannot read as UTF-8 text: {error}") from None
    header_line, _, body = text.partition("\n")
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
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise DataError(f"{path}: column(s) {', '.join(map(repr, duplicates))} appear more than once")
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
    return RawTable(
        time=data[:, 0].copy(),
        time_unit=columns[0][1],
        channels={name: data[:, i].copy() for i, (name, _) in enumerate(columns[1:], start=1)},
        units={name: unit for name, unit in columns[1:]},
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
