"""ASAM MDF rig files (`.mf4`, also MDF 3 `.mdf`) read and written with asammdf.

Every data channel must share one time base: channels of several groups are accepted only when their time stamps
are identical to within TIME_MATCH of the period (resample in the acquisition tool otherwise). Channel names and
units are the MDF channel names and units (two names for one channel, `force` and `Force`, are refused);
invalidated samples become NaN, so the checks report them.

Time stamps are binary floats, so no print rounding applies: a float64 (or integer) time channel is taken as exact
and only a clock's scatter of `timebase.CLOCK_SCATTER` is accepted; a float32 time channel is resolved to the float32
spacing at each stamp (7.6e-6 s between 64 and 128 s), which `timebase` accepts as it accepts print rounding.

A file asammdf cannot read is refused with one DataError; the traceback asammdf's destructor prints for an object
whose constructor failed (asammdf issues #248, #354) is swallowed while the file is read, and asammdf's own log
lines and debug dumps about the damage are held back. Before any samples are read, an MDF 4 file's record layout
is checked (every channel inside its group's records, the data blocks as long as the records they must hold):
asammdf's compiled reader trusts those numbers and crashes the process on a corrupt channel offset.
"""

from __future__ import annotations

import contextlib
import gc
import io
import logging
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from nnfmu.data.channel_map import first_duplicate
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.raw import RawTable
from nnfmu.data.timebase import Resolution, float32_resolution

if TYPE_CHECKING:  # asammdf (with pandas) is imported where an MDF file is read or written: 1.5-4 s of every
    from asammdf import MDF, Signal  # command's start otherwise, CSV records included

TIME_MATCH = 1e-9  # largest time-stamp difference between groups, relative to the period, that counts as the same
MDF_VERSION = "4.10"
IN_RECORD = (0, 1, 2, 4, 5)  # MDF 4 channel types stored in the record: fixed, VLSD offset, master, sync, max length


def _same_time_base(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    if a.size < 2:
        return bool(np.array_equal(a, b))
    period = (a[-1] - a[0]) / (a.size - 1)
    return bool(np.max(np.abs(a - b)) <= TIME_MATCH * abs(period))


def _samples(signal: Signal, name: str, path: Path) -> np.ndarray:
    samples = np.asarray(signal.samples)
    if samples.ndim != 1 or samples.dtype.kind not in "biuf":
        raise DataError(f"{path}: channel {name!r} holds {samples.dtype} samples of shape {samples.shape}, not numbers")
    values = samples.astype(np.float64)
    if signal.invalidation_bits is not None:
        values[np.asarray(signal.invalidation_bits, dtype=bool)] = np.nan
    return values


@contextlib.contextmanager
def _quiet_asammdf() -> Iterator[None]:
    """Hold back what asammdf prints while it reads: exceptions its `__del__` raises (and only those, until the
    block's garbage is collected), its log records and the debug dumps it prints to stdout."""
    previous = sys.unraisablehook
    logger = logging.getLogger("asammdf")
    was_disabled = logger.disabled

    def hook(unraisable: "sys.UnraisableHookArgs") -> None:
        if not str(getattr(unraisable.object, "__module__", "")).startswith("asammdf"):
            previous(unraisable)

    sys.unraisablehook = hook
    logger.disabled = True  # asammdf logs each damaged block before raising; the DataError says it once
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # and prints a debug dump of a channel it cannot read
            yield
    finally:
        gc.collect()  # a half-built MDF sits in a reference cycle: collect it while its destructor's error is swallowed
        sys.unraisablehook = previous
        logger.disabled = was_disabled


def _open(path: Path) -> MDF:
    """The file opened by asammdf; DataError (only) when asammdf cannot read it, whatever asammdf raised."""
    from asammdf import MDF

    try:
        return MDF(str(path))
    except Exception as error:  # a corrupt file can make asammdf's parser raise anything
        reason = f"{type(error).__name__}: {error}" if str(error) else type(error).__name__
    raise DataError(f"{path}: not a readable MDF file: {reason}")


def _check_layout(mdf: MDF, path: Path) -> None:
    """Refuse an MDF 4 file whose channels lie outside their records or whose data blocks are too short for them."""
    if not str(mdf.version).startswith("4"):
        return
    for group_index, group in enumerate(mdf.groups):
        record = group.channel_group.samples_byte_nr
        needed = group.channel_group.cycles_nr * (record + group.channel_group.invalidation_bytes_nr)
        stored = sum(block.original_size for block in group.data_blocks)
        if needed > stored:
            raise DataError(
                f"{path}: not a readable MDF file: group {group_index} declares {needed} bytes of records but its data "
                f"blocks hold {stored} (corrupt or partially written)"
            )
        for channel in group.channels:
            end = channel.byte_offset + (channel.bit_offset + channel.bit_count + 7) // 8
            if channel.channel_type in IN_RECORD and end > record:
                raise DataError(
                    f"{path}: not a readable MDF file: channel {channel.name!r} (group {group_index}) ends at byte "
                    f"{end} of records {record} bytes long (corrupt)"
                )


def _time_resolution(mdf: MDF, group_index: int, master_index: int | None, time: np.ndarray) -> Resolution | None:
    """float32 spacing for a 32-bit float time channel, None (exact) for any other."""
    if master_index is None:
        return None
    master = mdf.groups[group_index].channels[master_index]
    is_float = master.data_type in (4, 5)  # MDF 4 data types: IEEE 754 float, little and big endian
    return float32_resolution(time) if is_float and master.bit_count == 32 else None


def read_mdf(path: Path) -> RawTable:
    """Read every data channel of an MDF file as stored (units not converted); raise DataError on mixed time bases."""
    with _quiet_asammdf():
        mdf = _open(path)
        try:
            _check_layout(mdf, path)
            return _read_channels(mdf, path)
        except DataError:
            raise
        except Exception as error:  # corrupt data blocks surface only when the channels are read
            raise DataError(f"{path}: not a readable MDF file: {type(error).__name__}: {error}") from None
        finally:
            mdf.close()


def _read_channels(mdf: MDF, path: Path) -> RawTable:
    time: np.ndarray | None = None
    time_unit = "s"
    time_owner = ""
    resolution: Resolution | None = None
    channels: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    where: list[str] = []
    for group_index, group in enumerate(mdf.groups):
        master_index = mdf.masters_db.get(group_index)
        for channel_index, channel in enumerate(group.channels):
            if channel_index == master_index:
                continue
            name = channel.name
            clash = first_duplicate([*channels, name])
            if clash is not None:
                raise DataError(
                    f"{path}: channel {list(channels)[clash[0]]!r} ({where[clash[0]]}) and channel {name!r} (group "
                    f"{group_index}) name the same channel (names are compared ignoring case); keep one"
                )
            signal = mdf.get(group=group_index, index=channel_index)
            timestamps = np.asarray(signal.timestamps, dtype=np.float64)
            if time is None:
                time, time_owner = timestamps, name
                resolution = _time_resolution(mdf, group_index, master_index, timestamps)
                if master_index is not None and group.channels[master_index].unit:
                    time_unit = group.channels[master_index].unit
            elif not _same_time_base(time, timestamps):
                raise DataError(
                    f"{path}: channel {name!r} (group {group_index}, {timestamps.size} samples) has another time "
                    f"base than {time_owner!r} ({time.size} samples); resample to one time base first"
                )
            channels[name] = _samples(signal, name, path)
            units[name] = signal.unit or ""
            where.append(f"group {group_index}")
    if time is None:
        raise DataError(f"{path}: no data channels")
    for name, unit in units.items():
        if not unit:
            raise DataError(f"{path}: channel {name!r} has no unit")
    return RawTable(time=time, time_unit=time_unit, channels=channels, units=units, time_resolution=resolution)


def write_mdf(m: Measurement, path: Path) -> None:
    """Write `m` as one MDF 4 group with a common time base to `path` (exactly there; atomicity is the caller's)."""
    from asammdf import MDF, Signal

    time = np.asarray(m.time, dtype=np.float64)
    signals = [
        Signal(samples=np.asarray(values, dtype=np.float64), timestamps=time, name=name, unit=m.units[name])
        for name, values in m.channels.items()
    ]
    mdf = MDF(version=MDF_VERSION)
    try:
        mdf.append(signals, comment=f"nnfmu measurement from {m.source}", common_timebase=True)
        buffer = io.BytesIO()
        mdf.save(buffer, overwrite=True)
    finally:
        mdf.close()
    path.write_bytes(buffer.getvalue())
