"""System FMUs for `nnfmu cosim --engine compiled`, built once and kept: named by the hash of everything the build
reads (each element's FMU bytes, connectors, parameters, wiring, times, the coupling settings, the step, the drive
binding, nnfmu's version, the C templates, the co-simulation package's Python modules and the host compiler), so a
repeated run of the same system reuses its FMU and any change builds a new one. They live in the compiled helpers'
cache folder (`nnfmu.cosim.inner_loop.cache_dir`), unpacked (opened in place: no extraction per run) under
`system-fmus/`; at most KEPT of them, the least recently used removed after a build once unused for an hour (a run
in another process may still be opening it)."""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import shutil
import time
from pathlib import Path

from nnfmu.atomic import scratch_dir
from nnfmu.cosim.binding import DriveBinding
from nnfmu.cosim.container.build import HEADERS, build_system_fmu
from nnfmu.cosim.container.model_description import SOURCES
from nnfmu.cosim.inner_loop import cache_dir
from nnfmu.cosim.settings import CosimSettings
from nnfmu.cosim.ssp import SystemStructure
from nnfmu.out_paths import file_digest
from nnfmu.resources import templates_dir

FOLDER = "system-fmus"
KEPT = 32  # system FMUs kept in the cache (each about the size of its parts' FMUs)
IN_USE_S = 3600.0  # [s] a system FMU used this recently is never removed
STAMP = "modelDescription.xml"  # in every unpacked FMU; its time says when the FMU was last used


@functools.cache
def _builder_sha256() -> str:
    """What turns a system into a binary: the C templates and the co-simulation package's modules (the master's
    `_System` plans the system FMU), the engine's own two left out."""
    from nnfmu.fmu import GENERATION_TOOL, host_target

    target = host_target()
    digest = hashlib.sha256("\0".join((GENERATION_TOOL, *target.compiler, *target.flags)).encode())
    for path in sorted({templates_dir() / "c" / name for name in (*SOURCES[2], *HEADERS)}):
        digest.update(path.read_bytes())
    package = Path(__file__).parents[1]
    for path in sorted(package.rglob("*.py")):
        if path.parent.name == "container" and path.stem in ("cache", "engine"):
            continue
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def system_key(system: SystemStructure, settings: CosimSettings, binding: DriveBinding) -> str:
    """The hash naming the system FMU of `system` stepped at settings.step with the settings' coupling."""
    coupling = dataclasses.asdict(settings)
    for unused in ("stop_time", "start_time", "inner_loop", "tolerance"):  # the build does not read them
        coupling.pop(unused)
    identity = {
        "builder": _builder_sha256(),
        "name": system.name,
        "start_time": system.start_time,
        "stop_time": system.stop_time,
        "elements": [
            {
                "name": e.name,
                "fmu": file_digest(system.fmu_path(e)),
                "connectors": [[c.name, c.kind] for c in e.connectors],
                "parameters": {k: float(v) for k, v in e.parameters.items()},
            }
            for e in system.elements
        ],
        "connections": [dataclasses.astuple(c) for c in system.connections],
        "coupling": coupling,
        "binding": dataclasses.asdict(binding),
    }
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def cached_system_fmu(system: SystemStructure, settings: CosimSettings, binding: DriveBinding) -> tuple[Path, bool]:
    """The folder of the unpacked system FMU of `system` (inner step = settings.step, drive extrapolation on) in the
    cache, built there first if missing; and whether it was built now. CosimError naming what cannot be built."""
    from nnfmu.safe_zip import extract_zip

    key = system_key(system, settings, binding)
    folder = cache_dir() / FOLDER
    path = folder / key[:32]
    if (path / STAMP).is_file():
        os.utime(path / STAMP)  # recently used (the folder's own time stays: the instance pool keys on it)
        return path, False
    folder.mkdir(parents=True, exist_ok=True)
    with scratch_dir(".build-", folder) as scratch:
        fmu = Path(scratch) / "system.fmu"
        build_system_fmu(system, fmu, settings.step, None, settings, binding, fmi=2, platforms=("host",))
        unpacked = Path(scratch) / key[:32]
        extract_zip(fmu, unpacked)
        try:
            os.rename(unpacked, path)  # atomic: a concurrent run finds the whole folder or none
        except OSError:
            if not (path / STAMP).is_file():  # not another run's build of the same system
                raise
    _prune(folder, keep=path)
    return path, True


def _prune(folder: Path, keep: Path) -> None:
    """Remove the least recently used system FMUs beyond KEPT that have not been used for IN_USE_S."""
    entries = sorted(
        (p for p in folder.iterdir() if (p / STAMP).is_file()), key=lambda p: (p / STAMP).stat().st_mtime, reverse=True
    )
    now = time.time()
    for path in entries[KEPT:]:
        if path != keep and now - (path / STAMP).stat().st_mtime > IN_USE_S:
            shutil.rmtree(path, ignore_errors=True)
