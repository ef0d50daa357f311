"""Benchmark of issue 34's last criterion on a `nnfmu demo` run: its component networks' characterisations beside the
truth physics, judged against each network's own error and against a stricter one; the last stdout line is JSON.

`nnfmu demo` characterises each component network's FMU (the damper presets trained on the dyno's lab record, the
bushing presets on the bushing rig's) beside the rig's sine series at the lab record's levels, recorded without sensor
noise and with more cycles per level than the lab record's, the damper's without the dyno's moving mass, whose m·a
its networks learn without (`DEMO/rig/KIND_truth.csv`, report `DEMO/characterise_truth/PRESET/`): the truth physics'
characteristic at the lab series' test points. Its report
states per test point the deviation over the network's own error (the RMS error on the held-out test split of its
training record, noise included, which the FMU carries) and whether it is within; the counts here are read from it.

Beside them the stricter yardstick of `bench/characterise.py`: the FMU's RMS error on a held-out noise-free random
record (seed 1, 30 s), which leaves the sensor noise out of the own error; a point is within it when its deviation
(a damper's larger of rebound and jounce, a bushing's first-harmonic force deviation as an RMS) is at most that.
Both count the test points inside the network's training envelope (column `training_envelope`).

Usage: nnfmu demo --out DEMO; python bench/characterise_truth.py DEMO [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

from characterise import _csv, _own_error  # bench/ is on the path when a bench script runs

from nnfmu.workflows.demo import MOVING_MASS_BY_RIG, PRESETS_BY_RIG

TABLE = {"damper": "characteristic.csv", "bushing": "dynamic_stiffness.csv"}


def _deviation(kind: str, row: dict) -> float:
    """The deviation the report judges a point by, in the force's unit."""
    if kind == "damper":
        return max(abs(row["rebound_deviation [N]"]), abs(row["jounce_deviation [N]"]))
    (column,) = [c for c in row if c.startswith("harmonic_force_deviation_rms [")]
    return row[column]


def _point(kind: str, row: dict) -> dict:
    """A test point's place and its deviation as the report gives it."""
    if kind == "damper":
        where = {"peak_velocity_m/s": round(row["measured_peak_velocity [m/s]"], 4)}
    else:
        (amplitude,) = [c for c in row if c.startswith("amplitude [")]
        where = {"frequency_Hz": round(row["frequency [Hz]"], 3), "amplitude": row[amplitude]}
    return where | {
        "deviation": _deviation(kind, row),
        "deviation_over_own_error": row["deviation_over_own_error [1]"],
        "within_own_error": row["within_own_error"] == "yes",
        "training_envelope": row["training_envelope"],
    }


def bench_preset(kind: str, model: dict) -> dict:
    """One preset of the demo: its report beside the truth read back, and the stricter yardstick computed."""
    report = Path(model["truth_characterisation"])
    points = [_point(kind, row) for row in _csv(report.parent / TABLE[kind])]
    inside = [p for p in points if p["training_envelope"] == "inside"]
    clean = _own_error(Path(model["fmu"]), kind, MOVING_MASS_BY_RIG.get(kind, 0.0))
    for p in points:
        p["deviation_over_clean_error"] = p["deviation"] / clean["heldout_rms_error"]
    return {
        "fmu": model["fmu"],
        "report": str(report),
        "within_own_error": model["within_own_error_of_truth"],
        "largest_over_own_error": max(p["deviation_over_own_error"] for p in inside),
        "clean_record": clean,
        "within_clean_error": [sum(p["deviation_over_clean_error"] <= 1.0 for p in inside), len(inside)],
        "largest_over_clean_error": max(p["deviation_over_clean_error"] for p in inside),
        "points": points,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("demo", type=Path, help="the folder a `nnfmu demo` run wrote")
    parser.add_argument("--out", type=Path, help="also write the JSON document here")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    summary_path = args.demo / "summary.json"
    if not summary_path.is_file():
        sys.exit(f"{summary_path}: no such file (run `nnfmu demo --out {args.demo}` first)")
    summary = json.loads(summary_path.read_text(encoding="utf-8"))
    if summary["quick"]:
        sys.exit(f"{args.demo}: a quick demo (smoke-trained networks); run the full `nnfmu demo`")
    models = {m["preset"]: m for m in summary["models"]}
    presets = {preset: bench_preset(kind, models[preset]) for kind, names in PRESETS_BY_RIG.items() for preset in names}
    document = {
        "benchmark": "nnfmu demo's component networks characterised beside the truth physics (sine series, no noise)",
        "machine": {"python": platform.python_version(), "platform": platform.platform()},
        "demo": str(args.demo),
        "demo_seconds": summary["seconds"],
        "presets": presets,
        "seconds": round(time.perf_counter() - started, 1),
    }
    text = json.dumps(document)
    if args.out:
        args.out.write_text(text + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
