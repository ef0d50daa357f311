"""Run one case where it lands (a Dask worker, or this process): files from their bytes, co-simulate, score.

The files a case needs arrive as bytes keyed by SHA-256 and are written once per process into a cache folder (the
Dask worker's local directory, removed with the worker; else a temporary folder removed at exit), each under its
hash and its original name, so FMU and drive error messages name the user's file. FMU instances are kept in a
per-process pool and reset between cases (nnfmu.cosim.instances): opening an FMU costs about as much as a short
quarter-car case. Whatever goes wrong inside the case (a diverging coupling, a bad drive file, an FMU error, a
missing channel) becomes a failed outcome with its message; the caller records it and the campaign goes on.
"""

from __future__ import annotations

import atexit
import re
import shutil
import tempfile
import time
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nnfmu.atomic import atomic_path
from nnfmu.cosim import (
    Connection,
    Connector,
    CosimSettings,
    Element,
    InstancePool,
    SystemStructure,
    cosimulate_compiled,
)
from nnfmu.data import Measurement
from nnfmu.data.drive_files import read_drive
from nnfmu.errors import NnfmuError
from nnfmu.stopping import interrupts_deferred
from nnfmu.validate.compare import ValidationSettings
from nnfmu.validate.damage import pseudo_damage
from nnfmu.validate.metrics import rms
from nnfmu.vehicle import generate_drive
from nnfmu.workflows.campaign.cases import Case
from nnfmu.workflows.campaign.hashing import json_sha256
from nnfmu.workflows.campaign.spec import EventSpec, FileRef, drive_settings
from nnfmu.workflows.system import VirtualSystem

OK, FAILED = "ok", "failed"
DRIVES_KEPT = 4  # drives a process keeps in memory: the cases of one event usually follow each other
ERROR_CHARS = 2000  # longest error message kept in the table

_cache: Path | None = None
_drives: OrderedDict[str, Measurement] = OrderedDict()
_instances: InstancePool | None = None


@dataclass(frozen=True)
class ChannelRow:
    """The scores of one channel of one case, in the channel's SI unit (damage in unit^slope)."""

    channel: str
    unit: str
    rms: float
    peak: float
    valley: float
    damage: float
    basquin_slope: float


@dataclass(frozen=True)
class CaseOutcome:
    """What a case produced: `status` 'ok' with a row per channel, or 'failed' with the `error` message."""

    key: str
    event: str
    variant: str
    status: str
    error: str
    wall_s: float
    rows: tuple[ChannelRow, ...] = field(default=())


class CaseError(NnfmuError, RuntimeError):
    """A case ran but its result cannot be scored (a missing or non-finite channel); the message names it."""


def _cache_dir() -> Path:
    """This process's folder of materialised files (made on first use)."""
    global _cache
    if _cache is None:
        root = None
        try:
            from distributed import get_worker

            root = Path(get_worker().local_directory)
        except (ImportError, ValueError):
            pass  # not inside a Dask worker
        with interrupts_deferred():  # the folder and its cleanup come together
            _cache = Path(tempfile.mkdtemp(prefix="nnfmu-campaign-", dir=root))
            if root is None:
                atexit.register(shutil.rmtree, _cache, True)
    return _cache


def materialise(ref: FileRef, blobs: Mapping[str, bytes]) -> Path:
    """The file `ref` on this machine: written from its bytes on first use, under its hash and original name."""
    path = _cache_dir() / ref.sha256 / ref.name
    if not path.is_file():
        with atomic_path(path) as tmp:
            tmp.write_bytes(blobs[ref.sha256])
    return path


def load_drive(event: EventSpec, blobs: Mapping[str, bytes]) -> Measurement:
    """The event's drive: read from its file or generated from its settings (the latest few kept in memory)."""
    key = json_sha256({k: v for k, v in event.identity().items() if k != "name"})
    if key in _drives:
        _drives.move_to_end(key)
        return _drives[key]
    drive = (
        read_drive(materialise(event.drive, blobs)) if event.drive else generate_drive(drive_settings(event.generator))
    )
    _drives[key] = drive
    while len(_drives) > DRIVES_KEPT:
        _drives.popitem(last=False)
    return drive


def build_system(case: Case, blobs: Mapping[str, bytes]) -> VirtualSystem:
    """The variant's system with every element's FMU at its materialised path."""
    variant = case.variant
    elements = [
        Element(
            e.name, str(materialise(e.fmu, blobs)), tuple(Connector(n, k) for n, k in e.connectors), dict(e.parameters)
        )
        for e in variant.elements
    ]
    return VirtualSystem(  # sources already absolute, the cache's paths kept as `_message` strips them
        SystemStructure(
            variant.system_name,
            elements,
            [Connection(*c) for c in variant.connections],
            Path("/"),
            variant.start_time,
            variant.stop_time,
        )
    )


def score(result: Measurement, case: Case) -> tuple[ChannelRow, ...]:
    """RMS, peak, valley and rainflow pseudo-damage of each chosen channel (every output if none is chosen)."""
    metrics = case.metrics
    slopes = ValidationSettings(basquin_slope=metrics.basquin_slope, slopes=dict(metrics.slopes))
    missing = [c for c in metrics.channels if c not in result.channels]
    if missing:
        raise CaseError(f"the result has no channel {', '.join(map(repr, missing))} (has: {', '.join(result.names)})")
    rows = []
    for channel in metrics.channels or tuple(result.names):
        signal = result[channel]
        bad = ~np.isfinite(signal)
        if bad.any():
            raise CaseError(
                f"channel {channel!r} is not finite from t = {result.time[np.argmax(bad)]:.6g} s "
                "(the coupling diverged)"
            )
        slope = slopes.slope_for(channel)
        rows.append(
            ChannelRow(
                channel,
                result.units.get(channel, "1"),
                rms(signal),
                float(np.max(signal)),
                float(np.min(signal)),
                pseudo_damage(signal, slope),
                slope,
            )
        )
    return tuple(rows)


def _message(error: BaseException) -> str:
    """The error as one message, the cache folder and hash taken out of the paths it names (the file's name stays)."""
    text = f"{type(error).__name__}: {error}"
    if _cache is not None:
        text = re.sub(re.escape(str(_cache)) + r"/[0-9a-f]{64}/", "", text)
    return text[:ERROR_CHARS]


def instance_pool() -> InstancePool:
    """This process's pool of reset FMU instances (made on first use)."""
    global _instances
    if _instances is None:
        _instances = InstancePool()
    return _instances


def release_instances() -> None:
    """Close the instances this process keeps (after a serial run; a Dask worker keeps its own until it ends)."""
    global _instances
    if _instances is not None:
        _instances.close()
        _instances = None


def run_case(case: Case, blobs: Mapping[str, bytes], reuse_instances: bool = True) -> CaseOutcome:
    """Co-simulate and score one case on its engine (on reset instances from this process's pool, or
    `reuse_instances` False on freshly opened ones); any failure becomes a 'failed' outcome with its message."""
    started = time.perf_counter()
    try:
        drive = load_drive(case.event, blobs)
        system = build_system(case, blobs)
        settings, pool = CosimSettings(**case.coupling), instance_pool() if reuse_instances else None
        if case.engine == "compiled":
            result = cosimulate_compiled(system.structure, drive, settings, pool=pool, binding=system.drive_binding())
        else:
            result = system.cosimulate(drive, settings, pool=pool)
        rows = score(result.measurement, case)
    except Exception as error:  # the case's own failure: recorded, the campaign goes on
        return CaseOutcome(
            case.key, case.event.name, case.variant.name, FAILED, _message(error), time.perf_counter() - started
        )
    return CaseOutcome(case.key, case.event.name, case.variant.name, OK, "", time.perf_counter() - started, rows)


def run_cases(cases: Sequence[Case], blobs: Mapping[str, bytes], reuse_instances: bool = True) -> list[CaseOutcome]:
    """Run cases one after another (a Dask task holds several: fewer round trips to the scheduler)."""
    return [run_case(case, blobs, reuse_instances) for case in cases]
