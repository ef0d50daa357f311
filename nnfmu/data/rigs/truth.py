"""The ground-truth record of a simulated rig run, written beside the data. Only tests and reports may read it:
training and diagnosis must work from the measurement alone."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

from ... import __version__
from .options import RigOptions

TRUTH_SUFFIX = ".truth.json"
NOTICE = "Ground truth of a simulated rig run. Training and diagnosis must not read this file."


def truth_path(data_path: Path) -> Path:
    """`<data without suffix>.truth.json` beside the data file."""
    return data_path.with_name(data_path.stem + TRUTH_SUFFIX)


def build_truth(
    kind: str, effects: tuple[str, ...], parameters: dict[str, Any], excitation: dict[str, Any],
    sensors: dict[str, Any], options: RigOptions, duration: float, channels: dict[str, str],
) -> dict[str, Any]:
    """The truth dictionary: kind, effects on, every parameter with units, excitation, sensors, options, seed,
    channel units and nnfmu version."""
    return {
        "notice": NOTICE,
        "kind": kind,
        "effects": list(effects),
        "parameters": parameters,
        "excitation": excitation,
        "sensors": sensors,
        "options": dict(dataclasses.asdict(options), effects=list(effects), duration=duration),
        "seed": options.seed,
        "channels": channels,
        "nnfmu_version": __version__,
    }


def truth_text(truth: dict[str, Any]) -> str:
    """The truth as the JSON text of its file."""
    return json.dumps(truth, indent=2, allow_nan=False) + "\n"

