"""The header of an RPC III time-history file, read and checked before the `rpc3` package reads the file, so that a
bad header ends in one message naming the file and the field (the package's own messages name neither, or fail with
a TypeError on a number written without a decimal point).

The header is a sequence of 128-byte records, a key (32 bytes) and a value (96 bytes), latin-1, padded with NULs or
spaces: FORMAT, NUM_HEADER_BLOCKS and NUM_PARAMS first, then the other parameters.
"""

from __future__ import annotations

import math
from pathlib import Path

from nnfmu.component import SAMPLE_PERIOD_RANGE
from nnfmu.data.errors import DataError

RECORD = 128  # bytes of one header record: key 32 + value 96
MAX_PARAMS = 4 * 4096  # most header records read: 4096 header blocks of 4 records
FORMATS = ("BINARY", "BINARY_IEEE_LITTLE_END")
DATA_TYPES = ("SHORT_INTEGER", "FLOATING_POINT")
MAX_CHANNELS = 4096  # the integer fields are bounded so that no size computed from them is absurd
MAX_POINTS = 1 << 31


def read_rpc_header(path: Path) -> dict[str, str]:
    """The header's key -> value text; DataError naming the file and the record when it is not one."""
    with open(path, "rb") as handle:

        def record(index: int, expected: str | None) -> tuple[str, str]:
            data = handle.read(RECORD)
            if len(data) < RECORD:
                raise DataError(f"{path}: RPC III header ends at record {index + 1} (file too short)")
            key = data[:32].decode("latin-1").strip(" \0")
            value = data[32:].decode("latin-1").strip(" \0")
            if expected is not None and key != expected:
                raise DataError(f"{path}: RPC III header record {index + 1} is {key!r}, expected {expected!r}")
            return key, value

        header = dict([record(0, "FORMAT"), record(1, "NUM_HEADER_BLOCKS"), record(2, "NUM_PARAMS")])
        count = _integer(path, header, "NUM_PARAMS", 3, MAX_PARAMS)
        blocks = _integer(path, header, "NUM_HEADER_BLOCKS", 1, MAX_PARAMS // 4)
        if count > 4 * blocks:
            raise DataError(
                f"{path}: RPC III header field NUM_PARAMS = {count} does not fit in NUM_HEADER_BLOCKS = {blocks} "
                "blocks of 4 records"
            )
        for index in range(3, count):
            key, value = record(index, None)
            header[key] = value
    return header


def check_rpc_header(path: Path, header: dict[str, str]) -> None:
    """DataError naming the file and the field when a field nnfmu or the `rpc3` reader relies on is missing or
    out of range: FORMAT, FILE_TYPE, DATA_TYPE, DELTA_T (a sample period nnfmu accepts), CHANNELS, FRAMES,
    PTS_PER_FRAME, PTS_PER_GROUP, SAMPLES, and each channel's SCALE, DESC and UNITS."""
    if header["FORMAT"] not in FORMATS:
        raise DataError(f"{path}: RPC III header field FORMAT = {header['FORMAT']!r} is not one of {FORMATS}")
    if header.get("FILE_TYPE", "TIME_HISTORY") != "TIME_HISTORY":
        raise DataError(f"{path}: RPC III header field FILE_TYPE = {header['FILE_TYPE']!r}; only TIME_HISTORY is read")
    if header.get("DATA_TYPE", "SHORT_INTEGER") not in DATA_TYPES:
        raise DataError(f"{path}: RPC III header field DATA_TYPE = {header['DATA_TYPE']!r} is not one of {DATA_TYPES}")
    low, high = SAMPLE_PERIOD_RANGE
    period = _number(path, header, "DELTA_T")
    if not low <= period <= high:
        raise DataError(
            f"{path}: RPC III header field DELTA_T = {header['DELTA_T']!r} s is not a sample period in "
            f"[{low:g}, {high:g}] s"
        )
    channels = _integer(path, header, "CHANNELS", 1, MAX_CHANNELS)
    _integer(path, header, "FRAMES", 0, MAX_POINTS)
    _integer(path, header, "PTS_PER_FRAME", 1, MAX_POINTS)
    _integer(path, header, "PTS_PER_GROUP", 1, MAX_POINTS)
    if "SAMPLES" in header:
        _integer(path, header, "SAMPLES", 0, MAX_POINTS)
    for i in range(1, channels + 1):
        _number(path, header, f"SCALE.CHAN_{i}")
        for key in (f"DESC.CHAN_{i}", f"UNITS.CHAN_{i}"):
            if key not in header:
                raise DataError(f"{path}: RPC III header has no field {key} (CHANNELS = {channels})")
        if not header[f"DESC.CHAN_{i}"]:
            raise DataError(f"{path}: RPC III header field DESC.CHAN_{i} is empty: channel {i} needs a name")


def _field(path: Path, header: dict[str, str], key: str) -> str:
    if key not in header:
        raise DataError(f"{path}: RPC III header has no field {key}")
    return header[key]


def _number(path: Path, header: dict[str, str], key: str) -> float:
    """A finite real field written with a decimal point (the `rpc3` reader takes '1e-3' for text, not a number)."""
    text = _field(path, header, key)
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or "." not in text:
        raise DataError(
            f"{path}: RPC III header field {key} = {text!r} is not a finite number with a decimal point (e.g. 1.0E-03)"
        )
    return value


def _integer(path: Path, header: dict[str, str], key: str, low: int, high: int) -> int:
    text = _field(path, header, key)
    try:
        value = int(text)
    except ValueError:
        raise DataError(f"{path}: RPC III header field {key} = {text!r} is not a whole number") from None
    if not low <= value <= high:
        raise DataError(f"{path}: RPC III header field {key} = {value} is outside [{low}, {high}]")
    return value
