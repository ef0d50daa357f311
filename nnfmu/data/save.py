"""Write a `Measurement` as CSV or MDF 4, chosen by the file suffix, never leaving a half-written file."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from nnfmu.atomic import atomic_path
from nnfmu.data.checks import check_measurement
from nnfmu.data.csv_io import write_csv
from nnfmu.data.errors import DataError
from nnfmu.data.mdf_io import write_mdf
from nnfmu.data.measurement import Measurement

WRITERS: dict[str, Callable[[Measurement, Path], None]] = {".csv": write_csv, ".mf4": write_mdf}


def save_measurement(m: Measurement, path: str | os.PathLike[str]) -> Path:
    """Check `m` and write it to `path` (`.csv` or `.mf4`) through a temporary file and a rename; return the path.

    A measurement that `load_measurement` would refuse (non-SI units, NaN, non-uniform time) is refused here with
    DataError, so every file nnfmu writes reads back. `notes` are not stored.
    """
    path = Path(path)
    writer = WRITERS.get(path.suffix.lower())
    if writer is None:
        raise DataError(f"{path}: cannot write file type {path.suffix!r}; nnfmu writes {', '.join(WRITERS)}")
    check_measurement(m, min_samples=2)
    with atomic_path(path) as tmp:
        writer(m, tmp)
    return path
