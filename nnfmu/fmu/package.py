"""Zip an FMU folder into a `.fmu` file atomically (a failed build never leaves a partial `.fmu` behind), and say
which platforms' binaries a `.fmu` carries."""

from __future__ import annotations

import zipfile
from pathlib import Path

from nnfmu.atomic import atomic_path

# A fixed timestamp keeps the archive identical for identical contents.
ZIP_DATE = (2000, 1, 1, 0, 0, 0)


def package_fmu(tree: Path, target: Path) -> Path:
    """Write every file under `tree` into the zip `target` (paths relative to `tree`, `/`-separated, sorted)."""
    files = sorted(p for p in tree.rglob("*") if p.is_file())
    with atomic_path(target) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            for path in files:
                info = zipfile.ZipInfo(path.relative_to(tree).as_posix(), date_time=ZIP_DATE)
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                archive.writestr(info, path.read_bytes())
    return target


def binary_folders(fmu: Path) -> list[str]:
    """The `binaries/` subfolders of the FMU `fmu` that hold a shared library, in archive order."""
    with zipfile.ZipFile(fmu) as archive:
        names = archive.namelist()
    parts = (n.split("/") for n in names)
    return list(dict.fromkeys(p[1] for p in parts if len(p) == 3 and p[0] == "binaries" and p[1] and p[2]))
