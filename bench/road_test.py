"""The thesis's road-test cases at full length: quarter car and full vehicle on a 50 s class C drive (JSON out).

Usage: python bench/road_test.py [MODELS_DIR] [OUT_DIR] [DURATION_S]
MODELS_DIR holds <preset>.onnx for the two damper and four bushing presets (e.g. a demo's models/ folder); when it
does not exist they are trained there first on default rig records with the presets' default settings. DURATION_S
(default 50) shortens both systems' drives (20 s finishes in minutes on 2 cores). The co-simulations run the master
and the FMUs at their defaults. Progress goes to stderr; the last stdout line is one JSON object: run times,
`realtime_factor_full_vehicle` (simulated seconds per wall second of the full vehicle with the hysteresis damper
networks), the error `budget` (per system, channel and damper model: nrmse_total, nrmse_network, nrmse_coupling,
damage_ratio; see nnfmu/roadtest/budget.py), the thesis comparison, and the largest use of each network input's
training envelope.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from nnfmu.data.rigs import RigOptions, write_rig
from nnfmu.demo import MOVING_MASS_BY_RIG, PRESETS_BY_RIG
from nnfmu.models.workflow import TrainRequest, train_from_file
from nnfmu.roadtest import RoadTestSettings, SystemRun, run_road_test


def models_in(folder: Path, durations: dict[str, float] | None = None, **training: int) -> dict[str, Path]:
    """ONNX files of every preset in `folder`, training the missing ones on rig records (default length, or
    `durations` [s] per rig) with the preset's settings (overridden by `training`, e.g. restarts=1); the damper
    presets learn the force less the dyno's moving mass times acceleration, as in `nnfmu demo`."""
    models = {}
    for rig, presets in PRESETS_BY_RIG.items():
        lab = folder / "rig" / f"{rig}_lab.csv"
        for preset in presets:
            path = folder / f"{preset}.onnx"
            if not path.is_file():
                if not lab.is_file():
                    write_rig(rig, lab, RigOptions(seed=0, duration=(durations or {}).get(rig)))
                started = time.perf_counter()
                request = TrainRequest(preset=preset, moving_mass=MOVING_MASS_BY_RIG.get(rig, 0.0), **training)
                train_from_file(lab, request, path)
                print(f"trained {preset} in {time.perf_counter() - started:.1f} s", file=sys.stderr, flush=True)
            models[preset] = path
    return models


def main() -> None:
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("bench-out/models")
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("bench-out/road_test")
    duration = float(sys.argv[3]) if len(sys.argv) > 3 else 50.0
    started = time.perf_counter()
    models = models_in(folder)
    train_seconds = time.perf_counter() - started
    settings = RoadTestSettings(quarter_car=SystemRun(duration), full_vehicle=SystemRun(duration))
    result = run_road_test(out, models, settings, log=lambda line: print(line, file=sys.stderr, flush=True))
    summary = json.loads(result.summary.read_text())
    envelope = {}
    for system in summary["systems"]:
        for e in system["envelope"]:
            key = f"{system['system']}: {e['run']}: {e['element']}.{e['port']}"
            envelope[key] = max(envelope.get(key, 0.0), e["range_used"] or 0.0)
    full = next((s for s in summary["systems"] if s["system"] == "full-vehicle"), None)
    print(json.dumps({
        "duration_s": duration, "training_s": round(train_seconds, 1), "road_test_s": round(result.seconds, 1),
        "realtime_factor_full_vehicle": round(full["duration_s"] / full["seconds"]["damper-hysteresis"], 2)
        if full else None,
        "budget": [row for s in summary["systems"] for row in s["budget"]],
        "reports": {k: str(v) for k, v in result.reports().items()},
        "systems": [{k: s[k] for k in ("system", "seconds", "thesis_table")} for s in summary["systems"]],
        "largest_envelope_use": envelope,
    }, allow_nan=False))


if __name__ == "__main__":
    main()
