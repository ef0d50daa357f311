"""MTS 793 / TestSuite ASCII exports (`.dat`, `.txt`): blocks of data-acquisition output, read as one record.

Layout (MTS Series 793 application manual, "Data File Header"):
- line 1: `MTS793|program|language|version|delimiter|decimal|date sep|time sep|country|date format|time format|code`,
  e.g. `MTS793|MPT|ENU|1|2|.|/|:|1|0|0|A`; delimiter 1 is a comma ("Lotus", text in quotes), 2 a tab ("Excel"),
  0 a space ("plain": refused, since channel names contain spaces); decimal is `.` or `,`. When the line stops
  before the delimiter field, the delimiter is taken from the channel-name row (a tab, else a comma).
- one block per acquisition buffer: a `Data Acquisition` line (`Time:`, the start time, its unit, a date), a row of
  channel names, a row of units, then one row of values per sample, the time channel in any column; blank lines
  between blocks. A block may also start with the names row alone.
Every block must repeat the first block's channel names and units. Blocks are joined when each continues the time of
the one before (its first stamp one period after the last stamp before, within the time-base tolerance of
`timebase`), else refused naming the line. Unit spellings MTS uses that nnfmu's table lacks are translated
(MTS_UNITS: `Sec` -> `s`); channel names become nnfmu's as `mts_channels` says. Text is UTF-8, else Windows-1252
(the "ANSI" code page the header's last field announces).
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nnfmu.data.csv_io import MAX_HEADER_CHARS
from nnfmu.data.errors import DataError
from nnfmu.data.mts_channels import plan_channels
from nnfmu.data.raw import RawTable
from nnfmu.data.timebase import Resolution, printed_resolution, stamp_tolerance

SIGNATURE = "MTS793|"
MTS_UNITS: dict[str, str] = {"Sec": "s", "sec": "s", "Secs": "s", "secs": "s"}
DELIMITERS: dict[str, str] = {"1": ",", "2": "\t"}
DELIMITER_FIELD = 4
DECIMAL_FIELD = 5


def is_mts_export(path: Path) -> bool:
    """True when the file starts with the MTS 793 format line (`MTS793|...`)."""
    try:
        with path.open("rb") as stream:
            head = stream.read(len(SIGNATURE) + 3)
    except OSError:
        return False
    return head.removeprefix(b"\xef\xbb\xbf").startswith(SIGNATURE.encode())


@dataclass
class _Block:
    """One acquisition block: where its header lines are, its names and units, and its rows (line, cells)."""

    start_line: int
    info: str = ""
    names: list[str] | None = None
    names_line: int = 0
    units: list[str] | None = None
    units_line: int = 0
    rows: list[tuple[int, list[str]]] = field(default_factory=list)


@dataclass(frozen=True)
class _Format:
    program: str
    delimiter: str | None
    decimal: str


def _short(text: str) -> str:
    """A cell for a message, cut to 40 characters."""
    return repr(text if len(text) <= 40 else text[:40] + "...")


def _decode(path: Path) -> str:
    try:
        data = path.read_bytes()
    except OSError as error:
        raise DataError(f"{path}: cannot read: {error}") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("cp1252", errors="replace")


def _format(line: str, path: Path) -> _Format:
    fields = line.split("|")
    program = fields[1].strip() if len(fields) > 1 else ""
    decimal = fields[DECIMAL_FIELD].strip() if len(fields) > DECIMAL_FIELD else "."
    if decimal not in (".", ","):
        raise DataError(f"{path}: line 1: decimal separator {decimal!r}; nnfmu reads '.' or ','")
    if len(fields) <= DELIMITER_FIELD:
        return _Format(program, None, decimal)
    code = fields[DELIMITER_FIELD].strip()
    if code == "0":
        raise DataError(
            f"{path}: line 1: a space-delimited ('plain') MTS export cannot be split into channels whose names "
            f"contain spaces; export with tabs ('Excel') or commas ('Lotus')"
        )
    if code not in DELIMITERS:
        raise DataError(f"{path}: line 1: unknown delimiter code {code!r}; expected 1 (comma) or 2 (tab)")
    if DELIMITERS[code] == decimal:
        raise DataError(f"{path}: line 1: the decimal separator {decimal!r} is also the delimiter")
    return _Format(program, DELIMITERS[code], decimal)


def _header_cells(line: str, delimiter: str, number: int, path: Path) -> list[str]:
    """A names, units or `Data Acquisition` row split into stripped cells, trailing empty cells dropped."""
    if len(line) > MAX_HEADER_CHARS:
        raise DataError(f"{path}: line {number} is longer than {MAX_HEADER_CHARS} characters")
    try:
        cells = [cell.strip() for cell in next(csv.reader([line], delimiter=delimiter), [])]
    except csv.Error as error:
        raise DataError(f"{path}: line {number} cannot be split into cells: {error}") from None
    while cells and not cells[-1]:
        cells.pop()
    return cells


def _is_values(line: str, delimiter: str) -> bool:
    """True for a row of values: its first cell is a number (names and units rows start with text)."""
    try:
        float(line.split(delimiter, 1)[0])
    except ValueError:
        return False
    return True


def _blocks(lines: list[str], form: _Format, path: Path) -> list[_Block]:
    """Split the lines after line 1 into the acquisition blocks that hold rows of values."""
    delimiter = form.delimiter
    blocks: list[_Block] = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        if delimiter is None:
            delimiter = "\t" if "\t" in line else ","
        block = blocks[-1] if blocks else None
        values = line.replace(form.decimal, ".") if form.decimal != "." else line
        if _is_values(values, delimiter):
            if block is None or block.units is None:
                raise DataError(f"{path}: line {number}: values before a row of channel names and a row of units")
            cells = values.rstrip().split(delimiter)  # float() ignores the spaces around a number
            while len(cells) > len(block.names or ()) and not cells[-1].strip():
                cells.pop()
            block.rows.append((number, cells))
            continue
        cells = _header_cells(line, delimiter, number, path)
        if cells and cells[0].casefold().startswith("data acquisition"):
            blocks.append(_Block(start_line=number, info=" ".join(c for c in cells[1:] if c)))
        elif block is None or block.units is not None:
            blocks.append(_Block(start_line=number, names=cells, names_line=number))
        elif block.names is None:
            block.names, block.names_line = cells, number
        else:
            block.units, block.units_line = cells, number
    return [b for b in blocks if b.rows]


def _check_headers(blocks: list[_Block], path: Path) -> tuple[list[str], list[str]]:
    """The channel names and units every block repeats; DataError naming the line where a block differs."""
    first = blocks[0]
    names, units = first.names or [], first.units or []
    if len(units) != len(names):
        raise DataError(
            f"{path}: line {first.units_line} has {len(units)} units for the {len(names)} channel names at line "
            f"{first.names_line}"
        )
    for block in blocks[1:]:
        if block.names != names:
            raise DataError(
                f"{path}: line {block.names_line}: the channel names differ from those at line {first.names_line} "
                f"({', '.join(map(repr, block.names or []))} instead of {', '.join(map(repr, names))}); nnfmu joins "
                f"only blocks of the same channels"
            )
        if block.units != units:
            raise DataError(
                f"{path}: line {block.units_line}: the units differ from those at line {first.units_line} "
                f"({', '.join(map(repr, block.units or []))} instead of {', '.join(map(repr, units))})"
            )
    return names, units


def _values(blocks: list[_Block], names: list[str], path: Path) -> np.ndarray:
    """Every row of every block as numbers, shape (rows, channels); DataError naming the line and channel."""
    for block in blocks:
        for number, cells in block.rows:
            if len(cells) != len(names):
                raise DataError(
                    f"{path}: line {number} has {len(cells)} values, the channel names at line {block.names_line} "
                    f"{len(names)}"
                )
    try:
        return np.array([cells for block in blocks for _, cells in block.rows], dtype=np.float64)
    except ValueError:
        pass
    for block in blocks:
        for number, cells in block.rows:
            for column, cell in enumerate(cells):
                try:
                    float(cell)
                except ValueError:
                    raise DataError(
                        f"{path}: line {number}, channel {names[column]!r}: {_short(cell)} is not a number"
                    ) from None
    raise DataError(f"{path}: cannot read the rows of values")


def _check_joins(blocks: list[_Block], time: np.ndarray, resolution: Resolution | None, unit: str, path: Path) -> None:
    """Refuse, naming the line, a block whose first stamp is not one period after the block before's last."""
    ends = np.cumsum([len(b.rows) for b in blocks])
    inside = np.ones(max(time.size - 1, 0), dtype=bool)
    inside[ends[:-1] - 1] = False
    if not inside.any():
        return
    period = float(np.median(np.diff(time)[inside]))
    tolerance = stamp_tolerance(time, period, resolution)
    for before, block, start in zip(blocks[:-1], blocks[1:], ends[:-1]):
        step = time[start] - time[start - 1]
        if abs(step - period) > tolerance[start] + tolerance[start - 1]:
            raise DataError(
                f"{path}: line {block.rows[0][0]}: the acquisition block from line {block.start_line} does not "
                f"continue the time of the block before: t = {time[start]:.10g} {unit} follows t = "
                f"{time[start - 1]:.10g} {unit} at line {before.rows[-1][0]}, where one period "
                f"({period:.10g} {unit}) later is {time[start - 1] + period:.10g} {unit}; nnfmu joins blocks only "
                f"where the time runs on"
            )


def read_mts(path: Path, channel_map: Mapping[str, str] | None = None) -> RawTable:
    """Read an MTS 793 ASCII export as one table with nnfmu channel names (units not converted).

    Raises DataError naming the file and the line, column or channel at fault.
    """
    lines = _decode(path).splitlines()
    if not lines or not lines[0].startswith(SIGNATURE):
        raise DataError(f"{path}: not an MTS 793 export: the first line must start with {SIGNATURE!r}")
    form = _format(lines[0], path)
    blocks = _blocks(lines, form, path)
    if not blocks:
        raise DataError(f"{path}: no rows of values after the channel names and units")
    names, file_units = _check_headers(blocks, path)
    table = _values(blocks, names, path)
    units = [MTS_UNITS.get(unit, unit) for unit in file_units]
    plan = plan_channels(names, units, channel_map, str(path))
    time = table[:, plan.time]
    time_cells = [cells[plan.time] for block in blocks for _, cells in block.rows]
    resolution = printed_resolution(time_cells, time)
    _check_joins(blocks, time, resolution, units[plan.time], path)
    starts = ", ".join(str(block.start_line) for block in blocks)
    started = f"; the first: {blocks[0].info}" if blocks[0].info else ""
    return RawTable(
        time=time.copy(),
        time_unit=units[plan.time],
        channels={target: table[:, column].copy() for column, target in plan.names.items()},
        units={target: units[column] for column, target in plan.names.items()},
        time_resolution=resolution,
        notes={
            "format": f"MTS 793 {form.program or 'ASCII'} export, {len(blocks)} acquisition block(s) from lines "
            f"{starts}, joined{started}",
            "channels": plan.describe(names, file_units),
        },
    )
