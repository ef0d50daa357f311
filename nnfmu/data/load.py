"""Load a rig measurement from CSV, MDF or an MTS 793 export, in SI units, checked, on a uniform time base, with the
rates the rig did not measure derived."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from nnfmu.data.channel_map import rename_channels
from nnfmu.data.checks import check_measurement, check_sample_count
from nnfmu.data.csv_io import read_csv
from nnfmu.data.derive import derive_rates
from nnfmu.data.errors import DataError
from nnfmu.data.mdf_io import read_mdf
from nnfmu.data.measurement import Measurement
from nnfmu.data.mts_io import is_mts_export, read_mts
from nnfmu.data.raw import RawTable
from nnfmu.data.timebase import uniform_stamps
from nnfmu.data.units import SI_UNITS, to_si
from nnfmu.input_files import not_regular

READERS: dict[str, Callable[[Path], RawTable]] = {".csv": read_csv, ".mf4": read_mdf, ".mdf": read_mdf}
MTS_SUFFIXES = (".dat", ".txt")  # read only as MTS 793 exports; a `.csv` starting `MTS793|` is one too


def to_measurement(raw: RawTable, source: str, min_samples: int = 16) -> Measurement:
    """Convert every channel of a file's table to SI (see `units.to_si`) as a `Measurement` from `source` with at
    least `min_samples` samples, its stamps replaced by their least-squares uniform base where they stray within
    their resolution or a clock's scatter (said in `notes["time"]`; see `timebase`). The channels are taken out of
    `raw` as they are converted (its time and resolution too), so that a large table is not held twice."""
    time, _ = to_si(raw.time, raw.time_unit, "time", source)
    raw.time = time[:0]  # the stamps as stored are not needed any more: not held twice
    check_sample_count(len(time), min_samples, source)
    resolution = None
    if raw.time_resolution is not None:
        scale = float(to_si([1.0], raw.time_unit, "time", source)[0][0])
        resolution, raw.time_resolution = raw.time_resolution.scaled(scale), None
    channels = {}
    units = {}
    for name in list(raw.channels):
        channels[name], units[name] = to_si(raw.channels.pop(name), raw.units[name], name, source)
    notes = dict(raw.notes)
    kept = [f"{name} [{units[name]}]" for name in channels if units[name] not in SI_UNITS]
    if kept:
        notes["units"] = f"kept as declared (quantities nnfmu does not convert): {', '.join(kept)}"
    time, note = uniform_stamps(time, source, resolution)
    if note is not None:
        notes["time"] = note
    return Measurement(time=time, channels=channels, units=units, source=source, notes=notes)


def read_table(path: Path, channel_map: Mapping[str, str] | None = None) -> RawTable:
    """The file's table as stored, read by content (an MTS 793 export) or suffix, renamed by `channel_map`."""
    suffix = path.suffix.lower()
    known = [*READERS, *MTS_SUFFIXES]
    if suffix not in known:
        raise DataError(f"{path}: unknown file type {path.suffix!r}; nnfmu reads {', '.join(known)} (MTS 793 export)")
    if not path.is_file():
        raise DataError(f"{path}: {not_regular(Path(path)) or 'no such file'}")
    if is_mts_export(path):
        return read_mts(path, channel_map)
    if suffix in MTS_SUFFIXES:
        raise DataError(f"{path}: a {suffix} file is read as an MTS 793 export, whose first line starts 'MTS793|'")
    raw = READERS[suffix](path)
    return rename_channels(raw, channel_map, str(path)) if channel_map else raw


def _check_mapped(m: Measurement, required: Sequence[str]) -> None:
    """For a file whose channel names were mapped: name the missing required channels with the file's channels."""
    missing = [name for name in required if name not in m.channels]
    if missing and "channels" in m.notes:
        raise DataError(
            f"{m.source}: missing required channel(s) {', '.join(map(repr, missing))}; {m.notes['channels']}; name "
            f"the file channel that holds it with a channel map, e.g. --map 'NAME={missing[0]}'"
        )


def load_measurement(
    path: str | os.PathLike[str],
    required: Sequence[str] = (),
    min_samples: int = 16,
    channel_map: Mapping[str, str] | None = None,
) -> Measurement:
    """Read a `.csv`, `.mf4`/`.mdf` or MTS 793 export (`.dat`/`.txt`) rig file as a checked `Measurement` in SI units.

    `channel_map` renames file channels to nnfmu's names ({"Axial Force": "force"}; see `channel_map`). Stamps that
    are uniform within their printed resolution or a clock's scatter (5 % of the period) are replaced by the
    least-squares uniform base, said in `notes["time"]` (see `timebase`). Missing rates are derived (`derive_rates`),
    then the `required` channels must exist. Every problem (unknown file type, header, unit, NaN, time axis, missing
    channel, too few samples) raises DataError naming the file.
    """
    path = Path(path)
    measurement = to_measurement(read_table(path, channel_map), str(path), min_samples)
    check_measurement(measurement, min_samples=min_samples)
    measurement = derive_rates(measurement)
    _check_mapped(measurement, required)
    check_measurement(measurement, required=required, min_samples=min_samples)
    return measurement
