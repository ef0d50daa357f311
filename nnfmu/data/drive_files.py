"""Read and write drive files by suffix: CSV (`.csv`), MDF 4 (`.mf4`, also reads `.mdf`) and RPC III.

CSV and MDF go through nnfmu's rig-data loaders and savers (exact float64 round trip, `name [unit]` headers); a
drive file read back holds only the channels stored in it (the rates `load_measurement` derives are dropped).
RPC III (`.rsp`, `.drv`, `.tim`, `.rpc`; MTS time-history files) uses the `rpc3-file` package. RPC III stores
DELTA_T but no start time, so a written drive must start at t = 0 and reads back starting at 0. Its data are either
SHORT_INTEGER (int16, the usual drive format: each channel scaled to max|x| / 32752 per count, so a value comes back
within half a count, max|x| / 65504, plus float32 rounding) or FLOATING_POINT (float32: relative error <= 2^-24).
Units are stored per channel and converted to SI on reading (`mm` -> `m`).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Literal

import numpy as np
from rpc3 import rpc3 as rpc3_file

from nnfmu.atomic import atomic_path
from nnfmu.data.checks import check_measurement
from nnfmu.data.errors import DataError
from nnfmu.data.load import load_measurement
from nnfmu.data.measurement import Measurement
from nnfmu.data.rpc_header import check_rpc_header, read_rpc_header
from nnfmu.data.save import save_measurement
from nnfmu.data.units import to_si
from nnfmu.input_files import not_regular

MEASUREMENT_SUFFIXES = (".csv", ".mf4", ".mdf")
RPC_SUFFIXES = (".rsp", ".drv", ".tim", ".rpc")
RPC_TEXT_BYTES = 96  # longest channel name or unit an RPC III header value holds (latin-1)
START_TOLERANCE = 1e-9  # largest start time, relative to the period, that counts as t = 0 for RPC III
RpcDataType = Literal["int16", "float32"]


def _suffix(path: Path, writing: bool) -> str:
    suffix = path.suffix.lower()
    known = (".csv", ".mf4", *RPC_SUFFIXES) if writing else (*MEASUREMENT_SUFFIXES, *RPC_SUFFIXES)
    if suffix not in known:
        verb = "writes" if writing else "reads"
        raise DataError(f"{path}: unknown drive file type {suffix!r}; nnfmu {verb} {', '.join(known)}")
    return suffix


def write_drive(m: Measurement, path: str | os.PathLike[str], rpc_data_type: RpcDataType = "int16") -> Path:
    """Write drive `m` to `path` in the format its suffix names, via a temporary file and a rename; return the path.

    `rpc_data_type` chooses RPC III's int16 or float32 storage (see the module docstring). Raises DataError for an
    unknown suffix or a measurement the format cannot hold.
    """
    path = Path(path)
    if _suffix(path, writing=True) not in RPC_SUFFIXES:
        return save_measurement(m, path)
    if rpc_data_type not in ("int16", "float32"):
        raise DataError(f"{path}: RPC III data type {rpc_data_type!r} is neither 'int16' nor 'float32'")
    channels = _rpc_channels(m, path)
    with atomic_path(path) as tmp:
        # rpc3_file.write appends ".rpc" to names without an RPC suffix, so it writes to a name that has one.
        staging = tmp.with_name(tmp.name + ".rpc")
        try:
            with _quiet_rpc3():
                rpc3_file.write(
                    str(staging),
                    channels,
                    datatype=int if rpc_data_type == "int16" else float,
                    overwrite=True,
                    extra_params={"DELTA_T": _exact_text(m.sample_period), "TIME_TYPE": "DRIVE"},
                )
            os.replace(staging, tmp)
        finally:
            staging.unlink(missing_ok=True)
    return path


def read_drive(path: str | os.PathLike[str]) -> Measurement:
    """Read a drive file (CSV, MDF or RPC III by suffix) as a checked `Measurement` in SI units.

    Raises DataError naming the file for an unknown suffix, a missing or unreadable file, or bad channels.
    """
    path = Path(path)
    if _suffix(path, writing=False) in RPC_SUFFIXES:
        return _read_rpc(path)
    measurement = load_measurement(path)
    derived = [name for name in measurement.channels if f"derived:{name}" in measurement.notes]
    for name in derived:
        del measurement.channels[name], measurement.units[name], measurement.notes[f"derived:{name}"]
    return measurement


@contextmanager
def _quiet_rpc3() -> Iterator[None]:
    """Switch off rpc3's progress bar for one call (it prints to stderr by default)."""
    previous = rpc3_file.progressbar
    rpc3_file.progressbar = False
    try:
        yield
    finally:
        rpc3_file.progressbar = previous


def _exact_text(value: float) -> str:
    """A header value that reads back as the same float: rpc3 parses numbers with a '.' as float, others as int."""
    text = repr(float(value))
    return text if "." in text else np.format_float_scientific(value, unique=True)


def _header_text(text: str, what: str, path: Path) -> str:
    try:
        size = len(text.encode("latin-1"))
    except UnicodeEncodeError:
        raise DataError(f"{path}: {what} {text!r} has characters RPC III (latin-1) cannot store") from None
    if size > RPC_TEXT_BYTES or text != text.strip(" \0"):
        raise DataError(
            f"{path}: {what} {text!r} cannot be stored in RPC III (at most {RPC_TEXT_BYTES} characters, "
            f"no leading or trailing blanks)"
        )
    return text


def _rpc_channels(m: Measurement, path: Path) -> list[rpc3_file.Channel]:
    check_measurement(m, min_samples=2, source=f"{m.source} (writing {path})")
    period = m.sample_period
    if abs(float(m.time[0])) > START_TOLERANCE * period:
        raise DataError(
            f"{path}: RPC III stores no start time, but {m.source} starts at t = {float(m.time[0]):g} s; "
            f"shift its time axis to start at 0"
        )
    return [
        rpc3_file.Channel(
            name=_header_text(name, "channel name", path),
            unit=_header_text(m.units[name], f"unit of channel {name!r}", path),
            dt=period,
            data=np.asarray(values, dtype=np.float64),
        )
        for name, values in m.channels.items()
    ]


def _read_rpc(path: Path) -> Measurement:
    if not path.is_file():
        raise DataError(f"{path}: {not_regular(Path(path)) or 'no such file'}")
    try:
        check_rpc_header(path, read_rpc_header(path))
        with _quiet_rpc3():
            channels, params = rpc3_file.read(str(path))
    except OSError as error:
        raise DataError(f"{path}: cannot read the RPC III file: {error}") from None
    except (ValueError, KeyError, TypeError, IndexError, ArithmeticError) as error:
        if isinstance(error, DataError):
            raise
        raise DataError(f"{path}: not a readable RPC III time-history file (rpc3: {error})") from None
    if not channels:
        raise DataError(f"{path}: RPC III file without channels")
    source = str(path)
    values: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    for channel in channels:
        # rpc3 turns header values that look like numbers into int/float, names and units included.
        name, unit = str(channel.name), str(channel.unit)
        if name in values:
            raise DataError(f"{path}: channel {name!r} appears more than once")
        values[name], units[name] = to_si(np.asarray(channel.data, dtype=np.float64), unit, name, source)
    measurement = Measurement.uniform(
        0.0,
        float(params["DELTA_T"]),
        channels=values,
        units=units,
        source=source,
    )
    check_measurement(measurement)
    return measurement
