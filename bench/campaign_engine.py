"""A campaign's two engines: the example campaign's shape (10 generated events x 4 quarter-car damper variants of a
10 s drive, serial: `--workers 0`) run with `[coupling] engine = "python"` and `"compiled"`, the compiled one with
an empty system-FMU cache (each variant built first) and again with the cache filled. One JSON line.

Usage: python bench/campaign_engine.py [EVENTS] [VARIANTS] [DURATION_S] [REPEATS]
The C helpers (the master's inner loop, the engine's outer loop) are compiled before anything is timed, in a
private cache folder ($NNFMU_CACHE set for this process); the first python run warms the process (imports, drives).
Timed: `run_campaign` from reading the campaign to its summary written, wall clock and this process's CPU time
(user + sys, with its children: the compilers); `rows_match`: both engines' tables hold the same scores within
1e-12 relative.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

DAMPINGS = (2400.0, 1800.0, 3000.0, 3600.0, 4200.0, 1500.0, 2000.0, 2800.0)  # [N.s/m]


def cpu() -> float:
    """CPU seconds (user + sys) of this process and its finished children (the compilers)."""
    return sum(
        usage.ru_utime + usage.ru_stime
        for usage in (resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN))
    )


def campaign(
    folder: Path, paths: dict[str, Path], events: int, variants: list[str], duration: float, engine: str
) -> Path:
    lines = [
        'name = "engine bench"',
        f'[coupling]\nstep = 1e-3\nengine = "{engine}"',
        '[metrics]\nchannels = ["damper_force", "body_acceleration", "damper_displacement"]',
        f"[drive]\nduration = {duration}",
        f'[[events]]\nname = "C-20"\nclass = "C"\nspeed = 20.0\nrepeats = {events}',
    ]
    for name in variants:
        system, damper = paths["system"].name, paths[name].name
        lines.append(f'[[variants]]\nname = "{name}"\nsystem = "{system}"\nfmus = {{ damper = "{damper}" }}')
    path = folder / f"campaign-{engine}.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def timed(path: Path, out: Path) -> dict:
    from nnfmu.workflows.campaign import run_campaign

    shutil.rmtree(out, ignore_errors=True)
    wall, used = time.perf_counter(), cpu()
    run = run_campaign(path, out, workers=0)
    assert run.failed == 0, run
    return {"wall_s": time.perf_counter() - wall, "cpu_s": cpu() - used}


def scores(out: Path) -> np.ndarray:
    rows = sorted(
        pq.read_table(out / "results.parquet").to_pylist(), key=lambda r: (r["event"], r["variant"], r["channel"])
    )
    return np.array([[r[c] for c in ("rms", "peak", "valley", "damage")] for r in rows])


def main() -> None:
    events = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    n_variants = int(sys.argv[2]) if len(sys.argv) > 2 else 4
    duration = float(sys.argv[3]) if len(sys.argv) > 3 else 10.0
    repeats = int(sys.argv[4]) if len(sys.argv) > 4 else 3
    with tempfile.TemporaryDirectory(prefix="nnfmu-bench-engine-") as scratch:
        work = Path(scratch)
        os.environ["NNFMU_CACHE"] = str(work / "cache")
        from nnfmu.cosim.container.engine import _library
        from nnfmu.cosim.inner_loop import library
        from nnfmu.workflows.campaign.quarter_car import build_quarter_car_system

        library(), _library()
        variants = [f"v{i}" for i in range(n_variants)]
        paths = build_quarter_car_system(work, dict(zip(variants, DAMPINGS)))
        python = campaign(work, paths, events, variants, duration, "python")
        compiled = campaign(work, paths, events, variants, duration, "compiled")
        timed(python, work / "warm-up")
        runs: dict[str, list[dict]] = {"python": [], "compiled_cold": [], "compiled_warm": []}
        for _ in range(repeats):
            runs["python"].append(timed(python, work / "python"))
            shutil.rmtree(work / "cache" / "system-fmus", ignore_errors=True)
            runs["compiled_cold"].append(timed(compiled, work / "compiled"))
            runs["compiled_warm"].append(timed(compiled, work / "compiled"))
        a, b = scores(work / "python"), scores(work / "compiled")
        match = bool(a.shape == b.shape and np.all(np.abs(a - b) <= 1e-12 * np.maximum(np.abs(a), 1e-300)))
    record = {
        "cases": events * n_variants,
        "events": events,
        "variants": n_variants,
        "duration_s": duration,
        "repeats": repeats,
        "load_average": os.getloadavg(),
        "rows_match": match,
    }
    for name, values in runs.items():
        record[f"{name}_wall_s"] = round(statistics.median(v["wall_s"] for v in values), 3)
        record[f"{name}_cpu_s"] = round(statistics.median(v["cpu_s"] for v in values), 3)
        record[f"{name}_all_wall_s"] = [round(v["wall_s"], 3) for v in values]
    print(json.dumps(record))


if __name__ == "__main__":
    main()
