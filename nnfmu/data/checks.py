"""Checks that a `Measurement` is usable: SI units, enough samples, finite values, required channels (the
measurement checks its own time axis when it is made)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.units import SI_UNITS, channel_quantity, kept_unit

MIN_TEMPERATURE = 150.0  # K; rig temperatures lie far above (-123 degC), a value below is degC or degF labelled K


def check_measurement(
    m: Measurement,
    required: Sequence[str] = (),
    min_samples: int = 16,
    source: str | None = None,
) -> None:
    """Raise DataError naming `source` (default `m.source`) and the channel/sample at fault, else return None.

    In order: shapes and SI units of every channel, the `required` channels, at least `min_samples` samples,
    finite values, and temperatures of at least MIN_TEMPERATURE. The time axis was checked when `m` was made.
    """
    where = source if source is not None else m.source
    _check_layout(m, where)
    _check_required(m, required, where)
    check_sample_count(len(m), min_samples, where)
    _check_finite(m, where)
    _check_temperatures(m, where)


def check_sample_count(n: int, min_samples: int, where: str) -> None:
    """Raise DataError naming `where` unless a record of `n` samples has at least `min_samples`."""
    if n < min_samples:
        raise DataError(f"{where}: {n} samples, at least {min_samples} needed")


def _check_layout(m: Measurement, where: str) -> None:
    if "time" in m.channels:
        raise DataError(f"{where}: 'time' is the time axis and cannot also be a channel")
    for name, values in m.channels.items():
        if np.shape(values) != m.time.shape:
            raise DataError(f"{where}: channel {name!r} has shape {np.shape(values)}, the time axis {m.time.shape}")
        unit = m.units.get(name)
        if unit is None:
            raise DataError(f"{where}: channel {name!r} has no unit")
        quantity = channel_quantity(name)
        if quantity is not None and unit != quantity.si:
            raise DataError(
                f"{where}: channel {name!r} is a {quantity.name} in {unit!r}; it must be in {quantity.si!r}"
            )
        if quantity is None and unit not in SI_UNITS and not kept_unit(unit):
            raise DataError(
                f"{where}: channel {name!r} has unit {unit!r}, not one of the SI units {sorted(SI_UNITS)} nor a unit "
                "nnfmu keeps as declared"
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
    for name, values in m.channels.items():
        values = np.asarray(values, dtype=float)
        row = _first_bad(values)
        if row is not None:
            count = int(np.count_nonzero(~np.isfinite(values)))
            raise DataError(
                f"{where}: channel {name!r} has {count} non-finite value(s), the first {_g(values[row])} "
                f"at sample {row} (t = {_g(m.time[row])} s)"
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
