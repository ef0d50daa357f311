"""The damper-hysteresis preset trained with Levenberg-Marquardt's JᵀJ in float64 and in float32, seed by seed.

Both train `nnfmu train`'s way (the fixture's moving mass estimated from the record and taken out, or a fixed mass)
on the default damper dyno lab record (seed 0), with the preset's hidden sizes, at each training seed; per seed and
precision: the search's best validation MSE (scaled), the hidden size kept, the test split's NRMSE, the seconds
`train_from_file` took, and how many of the lab record's sine-series test points the network's FMU reproduces
within its own error (`nnfmu characterise --measured`, no figures). The training seed moves a network far more than
the precision does, so compare means over many seeds, not one. Progress goes to stderr; the last stdout line is one
JSON object.

Usage: python bench/lm_precision.py [--seeds 0,1,2,...] [--moving-mass auto|KG]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from nnfmu.data import load_measurement
from nnfmu.data.measurement import Measurement
from nnfmu.data.rigs import RigOptions, write_rig
from nnfmu.fmu import BuildOptions, build_fmu
from nnfmu.models import presets
from nnfmu.workflows.characterise import characterise
from nnfmu.workflows.characterise.settings import QUICK_SETTINGS
from nnfmu.workflows.train import TrainRequest, train_from_file

PRESET = "damper-hysteresis"
PRECISIONS = ("float64", "float32")


def _train(record: Path, lab: Measurement, out: Path, gram: str, seed: int, mass: float | None) -> dict[str, object]:
    """One `nnfmu train` of the preset with JᵀJ in `gram` at training seed `seed`, its FMU characterised beside `lab`
    (the record loaded)."""
    base = presets.PRESETS[PRESET]
    presets.PRESETS[PRESET] = replace(base, settings=replace(base.settings, lm_gram=gram))
    try:
        outcome = train_from_file(record, TrainRequest(preset=PRESET, seed=seed, moving_mass=mass), out)
    finally:
        presets.PRESETS[PRESET] = base
    trials = outcome.model.settings["validation_mse_by_hidden"]
    fmu = build_fmu(out, BuildOptions(out=out.with_suffix(".fmu")))
    within = characterise(fmu, out.with_suffix(""), lab, QUICK_SETTINGS, lambda _: None).within_own_error
    return {
        "best_validation_mse": min(trials.values()),
        "hidden": outcome.model.settings["hidden"],
        "test_nrmse": outcome.metrics["test"].nrmse,
        "seconds": round(outcome.seconds, 2),
        "test_points_within_own_error": list(within) if within else None,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2,3,4,5", help="training seeds, comma-separated")
    parser.add_argument("--moving-mass", default="auto", help="'auto' (estimated, as nnfmu train) or a mass [kg]")
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    mass = None if args.moving_mass == "auto" else float(args.moving_mass)
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        record, _truth = write_rig("damper", Path(tmp) / "damper_lab.csv", RigOptions(seed=0))
        lab = load_measurement(record)
        for seed in seeds:
            row: dict[str, object] = {"seed": seed}
            for gram in PRECISIONS:
                row[gram] = _train(record, lab, Path(tmp) / f"{gram}-{seed}.onnx", gram, seed, mass)
            print(json.dumps(row), file=sys.stderr, flush=True)
            runs.append(row)
    summary = {
        gram: {
            "mean_test_nrmse": float(np.mean([r[gram]["test_nrmse"] for r in runs])),
            "mean_best_validation_mse": float(np.mean([r[gram]["best_validation_mse"] for r in runs])),
            "median_seconds": float(np.median([r[gram]["seconds"] for r in runs])),
            "test_points_within_own_error": sum(r[gram]["test_points_within_own_error"][0] for r in runs),
            "test_points": sum(r[gram]["test_points_within_own_error"][1] for r in runs),
        }
        for gram in PRECISIONS
    }
    better = sum(r["float32"]["test_nrmse"] < r["float64"]["test_nrmse"] for r in runs)
    print(
        json.dumps(
            {
                "benchmark": "damper-hysteresis training, JᵀJ in float64 and float32",
                "moving_mass": args.moving_mass,
                "runs": runs,
                "summary": summary,
                "float32_better_test_nrmse": f"{better} of {len(runs)}",
            }
        )
    )


if __name__ == "__main__":
    main()
