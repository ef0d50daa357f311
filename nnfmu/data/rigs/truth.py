"""The ground-truth record of a simulated rig run, written beside the data. Only tests and reports may read it:
training and diagnosis must work from the measurement alone."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

from nnfmu import __version__
from nnfmu.data.rigs.options import RigOptions

TRUTH_SUFFIX = ".truth.json"
NOTICE = "Ground truth of a simulated rig run. Training and diagnosis must not read this file."


def truth_path(data_path: Path) -> Path:
    """`<data without suffix>.truth.json` beside the data file."""
    return data_path.with_name(data_path.stem + TRUTH_SUFFIX)


def build_truth(
    kind: str,
    effects: tuple[str, ...],
    parameters: dict[str, Any],
    excitation: dict[str, Any],
    sensors: dict[str, Any],
    options: RigOptions,
    duration: float,
    channels: dict[str, str],
) -> dict[str, Any]:
    """The truth dictionary: kind, effects on, every parameter with units, excitation, sensors, options, seed,
    channel units and nnfmu version. A semi-active damper's type is named beside the kind (a passive run's truth
    is as it was before damper types existed)."""
    settings = dict(dataclasses.asdict(options), effects=list(effects), duration=duration)
    damper_type = settings.pop("damper_type")
    return {
        "notice": NOTICE,
        "kind": kind,
        **({} if damper_type == "passive" else {"damper_type": damper_type}),
        "effects": list(effects),
        "parameters": parameters,
        "excitation": excitation,
        "sensors": sensors,
        "options": settings,
        "seed": options.seed,
        "channels": channels,
        "nnfmu_version": __version__,
    }


def truth_text(truth: dict[str, Any]) -> str:
    """The truth as the JSON text of its file."""
    return json.dumps(truth, indent=2, allow_nan=False) + "\n"
