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
from typing import TextIO

import numpy as np

from nnfmu.data.channel_map import first_duplicate
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.raw import RawTable
from nnfmu.data.timebase import combine_digits, digits_resolution, printed_digits

MAX_HEADER_CHARS = 65536  # a header of 1000 channels with 64-character names fits
CHUNK_CHARS = 1 << 20  # characters of data lines parsed at a time (a few MB of Python strings)
Digits = tuple[int, int] | None  # (significant digits, decimals) the time stamps show (`timebase.printed_digits`)

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


def _diagnose_rows(
    lines: list[str], delimiter: str, header: list[str], path: Path, reason: str, before: int = 0
) -> DataError:
    """The error for the first data line that does not parse (numbers as in the file, line 1 = the header, `before`
    data lines read before these)."""
    for offset, line in enumerate(lines):
        try:
            cells = next(csv.reader([line], delimiter=delimiter), [])
        except csv.Error as error:
            return DataError(f"{path}: line {before + offset + 2} cannot be split into cells: {error}")
        line = before + offset + 2
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


def _header_line(stream: TextIO, path: Path) -> str:
    """The header line without its line end; DataError for an overlong one, before the rest is read."""
    header_line = stream.readline(MAX_HEADER_CHARS + 1)
    if len(header_line) > MAX_HEADER_CHARS:
        raise DataError(
            f"{path}: the header line is longer than {MAX_HEADER_CHARS} characters; expected a header like "
            f"'time [s],displacement [m],force [N]'"
        )
    return header_line.rstrip("\r\n")


def _data_blocks(stream: TextIO, delimiter: str, header: list[str], path: Path) -> tuple[list[np.ndarray], Digits]:
    """The data rows as float64 blocks of about CHUNK_CHARS characters each, and the time column's printed digits:
    the text is parsed a chunk at a time, so it is never held whole."""
    blocks: list[np.ndarray] = []
    digits = None
    before = 0
    while True:
        chunk = stream.readlines(CHUNK_CHARS)
        if not chunk:
            return blocks, digits
        lines = [line.rstrip("\r\n") for line in chunk if line.strip()]
        del chunk
        if not lines:
            continue
        try:
            block = np.loadtxt(lines, delimiter=delimiter, ndmin=2, dtype=np.float64)
        except ValueError as error:
            raise _diagnose_rows(lines, delimiter, header, path, str(error), before) from None
        if block.shape[1] != len(header):
            raise _diagnose_rows(lines, delimiter, header, path, f"{block.shape[1]} values per row", before)
        digits = combine_digits(digits, printed_digits(line.split(delimiter, 1)[0] for line in lines))
        blocks.append(block)
        before += len(lines)


def _columns(blocks: list[np.ndarray], width: int) -> list[np.ndarray]:
    """Each column of the stacked `blocks` as its own contiguous array (the blocks are emptied on the way)."""
    n = sum(len(b) for b in blocks)
    columns = [np.empty(n) for _ in range(width)]
    row = 0
    while blocks:
        block = blocks.pop(0)
        for j, column in enumerate(columns):
            column[row : row + len(block)] = block[:, j]
        row += len(block)
    return columns


def _refuse_duplicates(names: list[str], header: list[str], path: Path) -> None:
    clash = first_duplicate(names)
    if clash is not None:
        a, b = clash
        raise DataError(
            f"{path}: column(s) {names[a]!r} appear more than once: column {a + 1} {header[a].strip()!r} and column "
            f"{b + 1} {header[b].strip()!r} name the same channel (names are compared ignoring case); keep one"
        )


def read_csv(path: Path) -> RawTable:
    """Read a CSV rig file as stored (units not converted); raise DataError naming the line or column at fault.
    The rows are parsed in chunks into float64 columns (peak memory about twice the columns' size)."""
    try:
        with path.open(encoding="utf-8-sig", newline="") as stream:
            header_line = _header_line(stream, path)
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
            blocks, digits = _data_blocks(stream, delimiter, header, path)
    except (OSError, UnicodeDecodeError) as error:
        raise DataError(f"{path}: cannot read as UTF-8 text: {error}") from None
    time, *values = _columns(blocks, len(columns))
    return RawTable(
        time=time,
        time_unit=columns[0][1],
        channels={name: column for (name, _), column in zip(columns[1:], values)},
        units={name: unit for name, unit in columns[1:]},
        time_resolution=digits_resolution(digits, time),
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
