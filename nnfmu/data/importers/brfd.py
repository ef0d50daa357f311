"""Read a BRFD file (measured banded rotary friction damper with backlash) into a `Measurement` in SI units.

Format (gzip-compressed JSON): `{"data": [[t, x, F, v, Fa1, Fa2], ...], "dt": ..., "sampling freq": ...,
"displacement units": "in", "friction force units": "kip", "time units": "s", ...}`, velocity in in/s. The two
actuator-force columns (band-tension actuator, lb) are not imported; rows of only the first four columns are
accepted too. The data's licence (CC BY-SA 4.0) and citation travel in `Measurement.notes["licence"]`.
"""

from __future__ import annotations

import gzip
import json
import os
import zlib
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from nnfmu.data.checks import check_measurement
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.units import to_si
from nnfmu.input_files import not_regular

BRFD_LICENCE = (
    'CC BY-SA 4.0. Cite: Coble, Huggins, Cao, Ricles, Downey, "Dataset-Friction-Damper-with-Backlash", 2022 '
    "(github.com/ARTS-Laboratory/Dataset-Friction-Damper-with-Backlash, commit "
    "0e09aa9d950760277e31c08cd93fd01f39a5af09). Anything derived from these data and shipped must keep this "
    "attribution and licence."
)

# column index, nnfmu channel, unit key in the file (None: fixed by the data set's description), default unit
COLUMNS = (
    (1, "displacement", "displacement units", "in"),
    (2, "force", "friction force units", "kip"),
    (3, "velocity", None, "in/s"),
)
TIME_COLUMN = 0
MIN_COLUMNS = 4


def _read_json(path: Path) -> dict:
    try:
        with gzip.open(path, "rt", encoding="utf-8") as stream:
            content = json.load(stream)
    except (OSError, EOFError, zlib.error) as err:
        raise DataError(f"{path}: not a readable gzip file ({err})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise DataError(f"{path}: not JSON after decompression ({err})") from None
    if not isinstance(content, dict) or "data" not in content:
        raise DataError(f"{path}: expected a JSON object with a 'data' table of rows [t, x, F, v, ...]")
    return content


def _table(path: Path, rows: object) -> np.ndarray:
    try:
        table = np.asarray(rows, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{path}: 'data' must be a table of numbers with the same column count in every row") from None
    if table.ndim != 2 or table.shape[1] < MIN_COLUMNS:
        raise DataError(
            f"{path}: 'data' has shape {table.shape}; expected rows of at least {MIN_COLUMNS} columns [t, x, F, v]"
        )
    return table


def _check_period(path: Path, content: dict, period: float) -> None:
    declared = content.get("dt")
    if declared is None:
        return
    if not np.isclose(period, float(declared), rtol=1e-3):
        raise DataError(f"{path}: time column steps by {period:g} s on average, but 'dt' says {declared!r} s")


def load_brfd(path: str | os.PathLike[str], min_samples: int = 16) -> Measurement:
    """A BRFD `.json.gz` file as a checked `Measurement`: displacement [m], velocity [m/s], force [N] (kip -> N).

    Raises DataError naming the file for an unreadable file, a malformed table, an unknown unit, a time axis that
    disagrees with `dt`, non-finite values or fewer than `min_samples` rows.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: {not_regular(Path(path)) or 'no such file'}")
    content = _read_json(path)
    table = _table(path, content["data"])
    time, _ = to_si(table[:, TIME_COLUMN], str(content.get("time units", "s")), "time", str(path))
    channels: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    for column, name, unit_key, default in COLUMNS:
        unit = str(content.get(unit_key, default)) if unit_key else default
        channels[name], units[name] = to_si(table[:, column], unit, name, str(path))
    measurement = Measurement(
        time=time,
        channels=channels,
        units=units,
        source=str(path),
        notes={
            "licence": BRFD_LICENCE,
            "instrument": "banded rotary friction damper with backlash on a servo-hydraulic actuator (Lehigh ATLSS)",
            "columns": "imported t, x, F, v; the actuator-force columns (lb) are not imported",
        },
    )
    check_measurement(measurement, min_samples=min_samples)
    _check_period(path, content, measurement.sample_period)
    return measurement


def load_brfd_series(paths: Sequence[str | os.PathLike[str]], min_samples: int = 16) -> Measurement:
    """Several BRFD runs joined in the given order into one record on a uniform time axis from 0 (each run starts
    and ends at rest, displacement and velocity near 0, so the motion is continuous at the joins); `notes["runs"]`
    lists each run's rows.

    Raises DataError naming the file whose sample period differs from the first run's, or as `load_brfd` does.
    """
    if not paths:
        raise DataError("no BRFD files given")
    runs = [load_brfd(path, min_samples) for path in paths]
    period = runs[0].sample_period
    for run in runs[1:]:
        if not np.isclose(run.sample_period, period, rtol=1e-9):
            raise DataError(
                f"{run.source}: sample period {run.sample_period:g} s differs from the {period:g} s of {runs[0].source}"
            )
    starts = np.cumsum([0] + [len(run) for run in runs])
    rows = "; ".join(f"{Path(run.source).name}: rows {a}-{b - 1}" for run, a, b in zip(runs, starts[:-1], starts[1:]))
    return Measurement.uniform(
        0.0,
        period,
        channels={name: np.concatenate([run[name] for run in runs]) for name in runs[0].names},
        units=dict(runs[0].units),
        source=" + ".join(run.source for run in runs),
        notes={**runs[0].notes, "runs": rows},
    )
