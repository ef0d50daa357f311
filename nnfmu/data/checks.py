"""Checks that a `Measurement` is usable: SI units, enough finite samples, a uniform time axis, required channels."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .errors import DataError
from .measurement import Measurement
from .units import SI_UNITS, channel_quantity

TIME_JITTER = 1e-3  # largest accepted deviation of one time step from the period, relative to the period
MIN_TEMPERATURE = 150.0  # K; rig temperatures lie far above (-123 degC), a value below is degC or degF labelled K


def check_measurement(
    m: Measurement, required: Sequence[str] = (), min_samples: int = 16, source: str | None = None
) -> None:
    """Raise DataError naming `source` (default `m.source`) and the channel/sample at fault, else return None.

    In order: shapes and SI units of every channel, the `required` channels, at least `min_samples` samples,
    finite values, a strictly increasing time axis whose steps deviate from the period by at most TIME_JITTER of
    it, and temperatures of at least MIN_TEMPERATURE.
    """
    where = source if source is not None else m.source
    _check_layout(m, where)
    _check_required(m, required, where)
    if len(m.time) < min_samples:
        raise DataError(f"{where}: {len(m.time)} samples, at least {min_samples} needed")
    _check_finite(m, where)
    _check_time(m.time, where)
    _check_temperatures(m, where)


def _check_layout(m: Measurement, where: str) -> None:
    time = np.asarray(m.time)
    if time.ndim != 1:
        raise DataError(f"{where}: time must have shape (n,), has shape {time.shape}")
    if "time" in m.channels:
        raise DataError(f"{where}: 'time' is the time axis and cannot also be a channel")
    for name, values in m.channels.items():
        if np.shape(values) != time.shape:
            raise DataError(f"{where}: channel {name!r} has shape {np.shape(values)}, the time axis {time.shape}")
        unit = m.units.get(name)
        if unit is None:
            raise DataError(f"{where}: channel {name!r} has no unit")
        quantity = channel_quantity(name)
        if quantity is not None and unit != quantity.si:
            raise DataError(
                f"{where}: channel {name!r} is a {quantity.name} in {unit!r}; it must be in {quantity.si!r}"
            )
        if quantity is None and unit not in SI_UNITS:
            raise DataError(
                f"{where}: channel {name!r} has unit {unit!r}, not one of the SI units {sorted(SI_UNITS)}"
            )


def _check_required(m: Measurement, required: Sequence[str], where: str) -> None:
    missing = [name for name in required if name not in m.channels]
    if missing:
        raise DataError(
            f"{where}: missing required channel(s) {', '.join(map(repr, missing))}; "
            f"it has: {', '.join(m.channels) or 'no channels'}"
        )


def _g(value: float) -> str:
    """A number for a message: 10 significant digits, no numpy type name."""
    return f"{float(value):.10g}"


def _first_bad(values: np.ndarray) -> int | None:
    bad = np.flatnonzero(~np.isfinite(values))
    return int(bad[0]) if bad.size else None


def _check_finite(m: Measurement, where: str) -> None:
    row = _first_bad(np.asarray(m.time, dtype=float))
    if row is not None:
        raise DataError(f"{where}: time is {_g(m.time[row])} at sample {row}")
    for name, values in m.channels.items():
        values = np.asarray(values, dtype=float)
        row = _first_bad(values)
        if row is not None:
            count = int(np.count_nonzero(~np.isfinite(values)))
            raise DataError(
                f"{where}: channel {name!r} has {count} non-finite value(s), the first {_g(values[row])} "
                f"at sample {row} (t = {_g(m.time[row])} s)"
            )


def _check_time(time: np.ndarray, where: str) -> None:
    steps = np.diff(np.asarray(time, dtype=float))
    if steps.size == 0:
        return
    not_increasing = np.flatnonzero(steps <= 0)
    if not_increasing.size:
        row = int(not_increasing[0]) + 1
        raise DataError(
            f"{where}: time does not increase at sample {row}: t = {_g(time[row - 1])} s then {_g(time[row])} s"
        )
    period = float(np.median(steps))
    jitter = np.abs(steps - period)
    off = np.flatnonzero(jitter > TIME_JITTER * period)
    if off.size:
        row = int(off[0]) + 1
        raise DataError(
            f"{where}: time is not uniformly sampled at sample {row} (t = {_g(time[row])} s): the step from the "
            f"previous sample is {_g(steps[row - 1])} s, the period {_g(period)} s (tolerance {TIME_JITTER:g} of it)"
        )


def _check_temperatures(m: Measurement, where: str) -> None:
    for name, values in m.channels.items():
        quantity = channel_quantity(name)
        is_temperature = quantity is not None and quantity.name == "temperature"
        if is_temperature and np.size(values) and np.min(values) < MIN_TEMPERATURE:
            row = int(np.argmin(values))
            raise DataError(
                f"{where}: channel {name!r} reaches {_g(values[row])} K at sample {row} (t = {_g(m.time[row])} s), "
                f"below the plausible {MIN_TEMPERATURE:g} K; is a temperature in degC or degF labelled K?"
            )
