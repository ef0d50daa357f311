"""`campaign.json`: what a campaign run was given (inputs, file hashes, settings), what ran it (versions, engine) and
what came out (counts, the table's hash), written atomically at the start of a run and again at its end."""

from __future__ import annotations

import dataclasses
import json
import platform
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

from nnfmu.atomic import write_text_atomic
from nnfmu.workflows.campaign.cases import PART_FORMAT, Case
from nnfmu.workflows.campaign.engine import EngineInfo
from nnfmu.workflows.campaign.spec import Campaign

RECORD = "campaign.json"
PACKAGES = ("nnfmu", "numpy", "scipy", "fmpy", "dask", "distributed", "pyarrow", "rainflow", "matplotlib")


def versions() -> dict[str, str]:
    """Python's and the packages' versions in this process."""
    found = {"python": platform.python_version(), "platform": platform.platform()}
    for package in PACKAGES:
        try:
            found[package] = version(package)
        except PackageNotFoundError:
            found[package] = "not installed"
    return found


def inputs(campaign: Campaign, cases: list[Case]) -> dict[str, Any]:
    """The campaign as read: file and hash, events, variants, settings, and every case's key."""
    return {
        "file": str(campaign.path),
        "sha256": campaign.sha256,
        "text": campaign.path.read_text(encoding="utf-8"),
        "name": campaign.name,
        "description": campaign.description,
        "events": [e.identity() for e in campaign.events],
        "variants": [v.identity() for v in campaign.variants],
        "coupling": {
            "given": dict(campaign.coupling),
            "resolved": campaign.resolved_coupling(),
            "engine": campaign.engine,
        },
        "metrics": campaign.metrics.identity() | {"reference": campaign.metrics.reference},
        "part_format": PART_FORMAT,
        "cases": [{"key": c.key, "event": c.event.name, "variant": c.variant.name} for c in cases],
    }


def write_record(out: Path, campaign_inputs: dict[str, Any], run: dict[str, Any], engine: EngineInfo | None) -> Path:
    """Write `out/campaign.json` (inputs, versions, engine, run)."""
    path = out / RECORD
    record = {
        "inputs": campaign_inputs,
        "versions": versions(),
        "engine": dataclasses.asdict(engine) if engine else None,
        "run": run,
    }
    write_text_atomic(path, json.dumps(record, indent=1, allow_nan=False) + "\n")
    return path
