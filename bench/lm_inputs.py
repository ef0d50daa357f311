"""The demo's damper network trained with Levenberg-Marquardt in several input coordinates, seed by seed.

Per training seed and per `TrainSettings.lm_inputs` ("raw" as trainlm, "standardised", "whitened"): the
damper-hysteresis preset trained as `nnfmu demo` trains it (the default damper dyno lab record, seed 0, the
fixture's 2 kg taken out), then `bench/characterise.py`'s damper comparison: the network's own error (its FMU's RMS
force error on a held-out noise-free random record), the test split's NRMSE, and how many of the characteristic
test's speeds it reproduces within that own error against the truth physics, with the worst point's deviation over
it, and each speed's rebound and jounce force deviation. The training seed moves a network more than the coordinates
do, so compare means over many seeds. `--knee-scale V` adds a second smoothed velocity sign, tanh(v/V), beside the
preset's friction sign (a feature at a digressive valve's knee, 0.1-0.3 m/s after Dixon), and then also runs the
preset as it is, in each coordinate system named ("+knee" marks those runs). Progress goes to stderr; the last
stdout line is one JSON object.

Usage: python bench/lm_inputs.py [--seeds 0,1,2,...] [--inputs raw,standardised] [--knee-scale M/S]
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
from nnfmu.models.features import SmoothSign
from nnfmu.models.lm import INPUT_COORDINATES
from nnfmu.workflows.train import TrainRequest

PRESET = "damper-hysteresis"


def _with_knee(preset: presets.Preset, scale: float | None) -> presets.Preset:
    """`preset` with tanh(v/scale) of its velocity after its friction sign (unchanged when `scale` is None)."""
    if scale is None:
        return preset
    derived = list(preset.spec.derived)
    at = next(i for i, d in enumerate(derived) if d.kind == "smooth_sign") + 1
    derived.insert(at, SmoothSign("velocity", scale=scale))
    return replace(preset, spec=replace(preset.spec, derived=tuple(derived)))


def _run(inputs: str, seed: int, folder: Path, knee: float | None = None) -> dict[str, object]:
    """The preset (with the knee feature when `knee` is a scale) trained in `inputs` coordinates at training seed
    `seed`, compared with the damper's truth."""
    base = presets.PRESETS[PRESET]
    presets.PRESETS[PRESET] = _with_knee(replace(base, settings=replace(base.settings, lm_inputs=inputs)), knee)
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
        "rebound_deviation_N": [round(p["rebound_deviation_N"], 3) for p in points],
        "jounce_deviation_N": [round(p["jounce_deviation_N"], 3) for p in points],
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2,3,4,5,6,7,8,9,10,11", help="training seeds, comma-separated")
    parser.add_argument("--inputs", default="raw,standardised", help="LM input coordinates, comma-separated")
    parser.add_argument("--knee-scale", type=float, help="velocity scale [m/s] of a second smoothed sign to try")
    args = parser.parse_args(argv)
    if args.knee_scale is not None and not args.knee_scale > 0:
        parser.error(f"--knee-scale {args.knee_scale} m/s: give a velocity > 0")
    seeds = [int(s) for s in args.seeds.split(",")]
    coordinates = args.inputs.split(",")
    if unknown := [k for k in coordinates if k not in INPUT_COORDINATES]:
        parser.error(f"unknown input coordinates {unknown}; known: {', '.join(INPUT_COORDINATES)}")
    variants = [(c, None) for c in coordinates]
    if args.knee_scale is not None:
        variants += [(c, args.knee_scale) for c in coordinates]
    kinds = [c if knee is None else f"{c}+knee" for c, knee in variants]
    runs = []
    for seed in seeds:
        row: dict[str, object] = {"seed": seed}
        for kind, (inputs, knee) in zip(kinds, variants, strict=True):
            with tempfile.TemporaryDirectory(prefix="nnfmu_lm_inputs_") as tmp:
                row[kind] = _run(inputs, seed, Path(tmp), knee)
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
                "knee_scale_m/s": args.knee_scale,
                "runs": runs,
                "summary": summary,
            }
        )
    )


if __name__ == "__main__":
    main()
