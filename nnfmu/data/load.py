"""Load a rig measurement from CSV or MDF, in SI units, checked, with the rates the rig did not measure derived."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

from .checks import check_measurement
from .csv_io import read_csv
from .derive import derive_rates
from .errors import DataError
from .mdf_io import read_mdf
from .measurement import Measurement
from .raw import RawTable
from .units import to_si

READERS: dict[str, Callable[[Path], RawTable]] = {".csv": read_csv, ".mf4": read_mdf, ".mdf": read_mdf}


def to_measurement(raw: RawTable, source: str) -> Measurement:
    """Convert every channel of a file's table to SI (see `units.to_si`) as a `Measurement` from `source`."""
    time, _ = to_si(raw.time, raw.time_unit, "time", source)
    channels = {}
    units = {}
    for name, values in raw.channels.items():
        channels[name], units[name] = to_si(values, raw.units[name], name, source)
    return Measurement(time=time, channels=channels, units=units, source=source)


def load_measurement(
    path: str | os.PathLike[str], required: Sequence[str] = (), min_samples: int = 16
) -> Measurement:
    """Read a `.csv`, `.mf4` or `.mdf` rig file as a checked `Measurement` in SI units.

    Missing rates are derived (`derive_rates`), then the `required` channels must exist. Every problem (unknown
    file type, header, unit, NaN, time axis, missing channel, too few samples) raises DataError naming the file.
    """
    path = Path(path)
    reader = READERS.get(path.suffix.lower())
    if reader is None:
        raise DataError(f"{path}: unknown file type {path.suffix!r}; nnfmu reads {', '.join(READERS)}")
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    measurement = to_measurement(reader(path), str(path))
    check_measurement(measurement, min_samples=min_samples)
    measurement = derive_rates(measurement)
    check_measurement(measurement, required=required, min_samples=min_samples)
    return measurement
