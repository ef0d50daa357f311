"""Peak memory of reading a large CSV rig file: `nnfmu data check` and `nnfmu train` (one epoch) on a
generated damper-dyno CSV of `--rows` rows (time, displacement, velocity, force; about 48 bytes a row), each command
in its own process, its peak RSS read from getrusage. Target (issue 30): at most about twice the data's size in
float64 for reading, and <= 1 GB for `data check` on 10 M rows. JSON lines, the summary last.

The summary's `data_check_within_target` says whether `data check` stayed within DATA_CHECK_TARGET_MB; `train` has
no target of its own (its peak holds the training: features, tensors and the optimiser besides the record).

Usage: nice python bench/csv_memory.py [--rows 10000000] [--no-train] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CHUNK_ROWS = 500_000  # rows generated and written at a time
DATA_CHECK_TARGET_MB = 1000.0  # issue 30: `data check` on 10 M rows within 1 GB


def write_csv(path: Path, rows: int) -> None:
    """A damper dyno record at 1 kHz: a 1.7 Hz sine stroke with noise, its velocity and a force."""
    rng = np.random.default_rng(0)
    with path.open("w", encoding="utf-8", newline="\n") as stream:
        stream.write("time [s],displacement [m],velocity [m/s],force [N]\n")
        for start in range(0, rows, CHUNK_ROWS):
            k = np.arange(start, min(rows, start + CHUNK_ROWS))
            t = k * 1e-3
            x = 0.02 * np.sin(2 * np.pi * 1.7 * t) + 1e-5 * rng.standard_normal(len(k))
            v = 0.02 * 2 * np.pi * 1.7 * np.cos(2 * np.pi * 1.7 * t)
            f = 1500.0 * v + 40.0 * np.sign(v) + rng.standard_normal(len(k))
            np.savetxt(stream, np.column_stack([t, x, v, f]), fmt=["%.3f", "%.6g", "%.6g", "%.6g"], delimiter=",")


def peak_of(command: list[str]) -> dict[str, object]:
    """Run `command` in a child (forked from a small helper so its peak is its own) and return its peak RSS."""
    probe = (
        "import resource, subprocess, sys; r = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
        "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
        "sys.stderr.write(r.stdout[-2000:] + r.stderr[-2000:])"
    )
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", probe, *command], capture_output=True, text=True)
    code, peak_kib = done.stdout.split()
    return {
        "exit": int(code),
        "peak_rss_mb": int(peak_kib) / 1024,
        "wall_s": round(time.perf_counter() - started, 1),
        "tail": done.stderr.strip().splitlines()[-1:] if done.stderr.strip() else [],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=10_000_000)
    parser.add_argument("--no-train", dest="train", action="store_false", help="only `nnfmu data check`")
    parser.add_argument("--keep", type=Path, default=None, help="write the CSV here and keep it")
    args = parser.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="nnfmu-csv-memory-"))
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"dyno_{args.rows}.csv"
    if not path.is_file():
        write_csv(path, args.rows)
    size_mb = path.stat().st_size / 1e6
    data_mb = args.rows * 4 * 8 / 1e6  # time + 3 channels in float64
    nnfmu = [sys.executable, "-m", "nnfmu.cli"]
    results = {"rows": args.rows, "file_mb": round(size_mb, 1), "float64_mb": round(data_mb, 1)}
    check = peak_of([*nnfmu, "data", "check", str(path)])
    print(json.dumps({"command": "data check", **check}), flush=True)
    results["data_check_peak_mb"] = round(check["peak_rss_mb"], 1)
    results["data_check_within_target"] = check["exit"] == 0 and check["peak_rss_mb"] <= DATA_CHECK_TARGET_MB
    if args.train:
        out = folder / "model.onnx"
        train = peak_of(
            [*nnfmu, "train", str(path), "--preset", "damper-spline", "--out", str(out), "--max-epochs", "1"]
            + ["--restarts", "1"]
        )
        print(json.dumps({"command": "train", **train}), flush=True)
        results["train_peak_mb"] = round(train["peak_rss_mb"], 1)
        results["train_exit"] = train["exit"]
    results["baseline_python_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    if args.keep is None:
        for p in folder.iterdir():
            p.unlink()
        os.rmdir(folder)
    print(json.dumps(results))


if __name__ == "__main__":
    main()
