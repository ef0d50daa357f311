"""Benchmark of the damper-semiactive preset on the MR and CDC dyno simulators; the last stdout line is JSON.

For each damper type (`nnfmu rig damper --type mr|cdc`, default lab record: 70 s, sine series and random stroke under a
lab-like command, realistic noise, seed 0): train damper-semiactive as `nnfmu train` does (the command's low-pass time
constants chosen by validation error), its `--recurrent` GRU, and for contrast the velocity-only damper-hysteresis net,
which cannot see the command. Each model then runs sample by sample from rest over a separate held-out record (random
stroke and random command, seed 1) and is compared with the true, noise-free force of that run (and with the noisy
measured one). Reference points from the issue, measured by hand on a public MR record: a time-delay network on the
command (delays 0, 3, 10, 30 samples) 15.2 % NRMSE, a recurrent one 10.8 %.

Usage: python bench/semiactive.py [--types mr cdc] [--models semiactive semiactive-gru hysteresis]
                                  [--test-duration S] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import torch

from nnfmu.data import load_measurement
from nnfmu.data.rigs import COMMAND_CHANNELS, RigOptions, simulate_rig, write_rig
from nnfmu.models.metrics import nrmse
from nnfmu.workflows.train import TrainRequest, train_from_file

MODELS = {
    "semiactive": TrainRequest("damper-semiactive"),
    "semiactive-gru": TrainRequest("damper-semiactive", recurrent=True),
    "hysteresis": TrainRequest("damper-hysteresis"),
}


def bench_model(name: str, lab: Path, held_out, true, folder: Path) -> dict:
    """Train model `name` on the lab record file; its held-out errors, network and training time."""
    started = time.perf_counter()
    outcome = train_from_file(lab, MODELS[name], folder / f"{lab.stem}_{name}.onnx")
    seconds = time.perf_counter() - started
    model = outcome.model
    prediction = model.predict({c: held_out[c] for c in model.spec.channels})
    return {
        "network": f"{model.settings['kind']} {model.spec.n_features}-{model.settings['hidden']}-1",
        "features": model.spec.feature_names,
        "feature_choice_validation_mse": {
            ", ".join(n for n in spec.feature_names if n.startswith("lowpass")): mse
            for spec, mse in outcome.feature_choice
        },
        "train_seconds": round(seconds, 1),
        "split_nrmse": {split: m["nrmse"] for split, m in model.metrics.items()},
        "heldout_nrmse_vs_true": nrmse(prediction, true["force"]),
        "heldout_nrmse_vs_measured": nrmse(prediction, held_out["force"]),
    }


def bench_type(damper_type: str, models: list[str], test_duration: float, folder: Path) -> dict:
    """Every model on one damper type's lab record, judged on its held-out random record."""
    lab, _ = write_rig("damper", folder / f"{damper_type}_lab.csv", RigOptions(seed=0, damper_type=damper_type))
    held = RigOptions(seed=1, damper_type=damper_type, excitation="random", duration=test_duration)
    held_path, _ = write_rig("damper", folder / f"{damper_type}_heldout.csv", held)
    held_out = load_measurement(held_path)
    true = simulate_rig("damper", RigOptions(**{**held.__dict__, "noise": 0.0})).measurement
    results = {}
    for name in models:
        results[name] = bench_model(name, lab, held_out, true, folder)
        print(f"{damper_type} {name}: {results[name]['heldout_nrmse_vs_true']:.4f}", file=sys.stderr, flush=True)
    return {"command_channel": COMMAND_CHANNELS[damper_type], "models": results}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--types", nargs="+", default=list(COMMAND_CHANNELS), choices=list(COMMAND_CHANNELS))
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--test-duration", type=float, default=30.0, help="held-out random record length [s]")
    parser.add_argument("--out", type=Path, help="also write the JSON document here")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nnfmu_semiactive_") as tmp:
        types = {t: bench_type(t, args.models, args.test_duration, Path(tmp)) for t in args.types}
    document = {
        "benchmark": "damper-semiactive on the MR and CDC dyno simulators",
        "machine": {
            "python": platform.python_version(),
            "torch": torch.__version__,
            "threads": torch.get_num_threads(),
        },
        "test_duration_s": args.test_duration,
        "issue_reference_nrmse": {"time_delay_net": 0.152, "recurrent": 0.108},
        "types": types,
        "seconds": round(time.perf_counter() - started, 1),
    }
    text = json.dumps(document)
    if args.out:
        args.out.write_text(text + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
