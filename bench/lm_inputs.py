"""The demo's damper network trained with Levenberg-Marquardt in several input coordinates, seed by seed.

Per training seed and per `TrainSettings.lm_inputs` ("raw" as trainlm, "standardised", "whitened"): the
damper-hysteresis preset trained as `nnfmu demo` trains it (the default damper dyno lab record, seed 0, the
fixture's 2 kg taken out), then `bench/characterise.py`'s damper comparison: the network's own error (its FMU's RMS
force error on a held-out noise-free random record), the test split's NRMSE, and how many of the characteristic
test's speeds it reproduces within that own error against the truth physics, with the worst point's deviation over
it. The training seed moves a network more than the coordinates do, so compare means over many seeds. Progress goes
to stderr; the last stdout line is one JSON object.

Usage: python bench/lm_inputs.py [--seeds 0,1,2,...] [--inputs raw,standardised]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import characterise as characterise_bench  # bench/ is on the path when a bench script runs
import numpy as np

from nnfmu.models import presets
from nnfmu.models.lm import INPUT_COORDINATES
from nnfmu.workflows.train import TrainRequest

PRESET = "damper-hysteresis"


def _run(inputs: str, seed: int, folder: Path) -> dict[str, object]:
    """The preset trained in `inputs` coordinates at training seed `seed`, compared with the damper's truth."""
    base = presets.PRESETS[PRESET]
    presets.PRESETS[PRESET] = replace(base, settings=replace(base.settings, lm_inputs=inputs))
    request = characterise_bench._request
    characterise_bench._request = lambda preset, quick, mass: TrainRequest(preset, moving_mass=mass, seed=seed)
    try:
        result = characterise_bench.bench_damper(False, folder)
    finally:
        presets.PRESETS[PRESET] = base
        characterise_bench._request = request
    points = result["points_vs_truth"]
    return {
        "heldout_rms_error_N": result["network"]["heldout_rms_error"],
        "test_nrmse": result["network"]["test_split_nrmse"],
        "speeds_within_own_error": result["within_own_error"],
        "worst_deviation_over_own_error": max(
            max(p["rebound_over_own_error"], p["jounce_over_own_error"]) for p in points
        ),
        "train_seconds": result["network"]["train_seconds"],
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2,3,4,5,6,7,8,9,10,11", help="training seeds, comma-separated")
    parser.add_argument("--inputs", default="raw,standardised", help="LM input coordinates, comma-separated")
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    kinds = args.inputs.split(",")
    if unknown := [k for k in kinds if k not in INPUT_COORDINATES]:
        parser.error(f"unknown input coordinates {unknown}; known: {', '.join(INPUT_COORDINATES)}")
    runs = []
    for seed in seeds:
        row: dict[str, object] = {"seed": seed}
        for kind in kinds:
            with tempfile.TemporaryDirectory(prefix="nnfmu_lm_inputs_") as tmp:
                row[kind] = _run(kind, seed, Path(tmp))
        print(json.dumps(row), file=sys.stderr, flush=True)
        runs.append(row)
    summary = {
        kind: {
            "mean_heldout_rms_error_N": float(np.mean([r[kind]["heldout_rms_error_N"] for r in runs])),
            "mean_test_nrmse": float(np.mean([r[kind]["test_nrmse"] for r in runs])),
            "speeds_within_own_error": sum(r[kind]["speeds_within_own_error"][0] for r in runs),
            "speeds": sum(r[kind]["speeds_within_own_error"][1] for r in runs),
            "seeds_with_every_speed_within": sum(
                r[kind]["speeds_within_own_error"][0] == r[kind]["speeds_within_own_error"][1] for r in runs
            ),
            "median_train_seconds": float(np.median([r[kind]["train_seconds"] for r in runs])),
        }
        for kind in kinds
    }
    print(
        json.dumps(
            {
                "benchmark": "the demo's damper-hysteresis network (2 kg taken out) by LM input coordinates and seed",
                "runs": runs,
                "summary": summary,
            }
        )
    )


if __name__ == "__main__":
    main()
