"""How many of a bushing preset's search runs give energy back, with and without its 3 ms memory branch (JSON out).

Usage: python bench/passivity_runs.py [--presets NAME ...] [--seeds N ...]
For each preset (default: the two with a 3 ms branch, radial force and axial torque) and training seed, the preset
is trained on the bushing rig's lab record (seed 0, default effects and noise) as `nnfmu train` trains it, once with its
default features and once without the high-passes faster than `MEMORY_TAUS` (the bank the other bushing presets use);
every run of the search (hidden size x restart) is put through the passivity check (`passivity_refusals`, the check
`nnfmu train` asks before it keeps a network). Reported per preset, variant and seed: the runs checked, those refused,
whether the search's own choice was refused. Progress goes to stderr; the last stdout line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace

from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.models.presets import MEMORY_TAUS, get_preset
from nnfmu.models.train import train_model
from nnfmu.workflows.train import passivity_refusals

PRESETS = ("bushing-radial-force", "bushing-axial-torque")


def without_fast_branches(spec):
    """`spec` without the high-passes faster than the default bank's."""
    kept = tuple(d for d in spec.derived if not (d.kind == "highpass" and d.tau < min(MEMORY_TAUS)))
    return replace(spec, derived=kept)


def checked_runs(name: str, spec, lab, seed: int) -> dict:
    """Train `name` on `lab` with `spec` and training seed `seed`, checking every run of the search for passivity."""
    preset = get_preset(name)
    verdicts: list[bool] = []

    def check_all(model) -> list[str]:
        verdicts.append(bool(passivity_refusals(name, model)))
        return ["asking for the next run"]  # refusing each one makes training check them all

    started = time.perf_counter()
    train_model(lab, spec, preset.architecture, replace(preset.settings, seed=seed), accept=check_all)
    return {
        "runs": len(verdicts),
        "refused": sum(verdicts),
        "choice_refused": verdicts[0],
        "seconds": round(time.perf_counter() - started, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", nargs="+", default=list(PRESETS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    args = parser.parse_args()
    lab = simulate_rig("bushing", RigOptions(seed=0)).measurement
    rows = []
    for name in args.presets:
        spec = get_preset(name).spec
        for variant, features in (("default", spec), ("without_fast_branch", without_fast_branches(spec))):
            for seed in args.seeds:
                row = {"preset": name, "variant": variant, "seed": seed} | checked_runs(name, features, lab, seed)
                print(json.dumps(row), file=sys.stderr, flush=True)
                rows.append(row)
    totals: dict[str, list[int]] = {}
    for row in rows:
        refused_and_runs = totals.setdefault(f"{row['preset']}/{row['variant']}", [0, 0])
        refused_and_runs[0] += row["refused"]
        refused_and_runs[1] += row["runs"]
    print(json.dumps({"record": "bushing rig, lab drive, seed 0", "rows": rows, "refused_of_runs": totals}))


if __name__ == "__main__":
    main()
