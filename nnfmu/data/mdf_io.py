"""ASAM MDF rig files (`.mf4`, also MDF 3 `.mdf`) read and written with asammdf.

Every data channel must share one time base: channels of several groups are accepted only when their time stamps
are identical to within TIME_MATCH of the period (resample in the acquisition tool otherwise). Channel names and
units are the MDF channel names and units; invalidated samples become NaN, so the checks report them.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from asammdf import MDF, Signal
from asammdf.blocks.utils import MdfException

from .errors import DataError
from .measurement import Measurement
from .raw import RawTable

TIME_MATCH = 1e-9  # largest time-stamp difference between groups, relative to the period, that counts as the same
MDF_VERSION = "4.10"


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


def read_mdf(path: Path) -> RawTable:
    """Read every data channel of an MDF file as stored (units not converted); raise DataError on mixed time bases."""
    try:
        mdf = MDF(str(path))
    except (MdfException, OSError, ValueError) as error:
        raise DataError(f"{path}: not a readable MDF file: {error}") from None
    try:
        time: np.ndarray | None = None
        time_unit = "s"
        time_owner = ""
        channels: dict[str, np.ndarray] = {}
        units: dict[str, str] = {}
        for group_index, group in enumerate(mdf.groups):
            master_index = mdf.masters_db.get(group_index)
            for channel_index, channel in enumerate(group.channels):
                if channel_index == master_index:
                    continue
                name = channel.name
                if name in channels:
                    raise DataError(f"{path}: channel {name!r} appears in more than one group")
                signal = mdf.get(group=group_index, index=channel_index)
                timestamps = np.asarray(signal.timestamps, dtype=np.float64)
                if time is None:
                    time, time_owner = timestamps, name
                    if master_index is not None and group.channels[master_index].unit:
                        time_unit = group.channels[master_index].unit
                elif not _same_time_base(time, timestamps):
                    raise DataError(
                        f"{path}: channel {name!r} (group {group_index}, {timestamps.size} samples) has another time "
                        f"base than {time_owner!r} ({time.size} samples); resample to one time base first"
                    )
                channels[name] = _samples(signal, name, path)
                units[name] = signal.unit or ""
    finally:
        mdf.close()
    if time is None:
        raise DataError(f"{path}: no data channels")
    for name, unit in units.items():
        if not unit:
            raise DataError(f"{path}: channel {name!r} has no unit")
    return RawTable(time=time, time_unit=time_unit, channels=channels, units=units)


def write_mdf(m: Measurement, path: Path) -> None:
    """Write `m` as one MDF 4 group with a common time base to `path` (exactly there; atomicity is the caller's)."""
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
