"""The thesis's road-test cases at full length: quarter car and full vehicle on a 50 s class C drive (JSON out).

Usage: python bench/road_test.py [MODELS_DIR] [OUT_DIR] [DURATION_S] [--bushings vehicle|lab] [--dampers vehicle|lab]
    [--training-seed N]
MODELS_DIR holds <preset>.onnx for the two damper and four bushing presets (e.g. a demo's models/ folder); when it
does not exist they are trained there first on default rig records with the presets' default settings. With
`--bushings vehicle` (the default, as in `nnfmu demo`) the road test's bushing networks are instead trained on a rig
record derived from the vehicle's own bushing deflections on another drive seed (`train_vehicle_bushings`, in
OUT_DIR/vehicle_bushing); `lab` keeps MODELS_DIR's. With `--dampers vehicle` (the default, as in `nnfmu demo`) both
damper networks are trained on a dyno record whose random part follows the car's damper strokes in the same source
reference (`train_vehicle_dampers`, in OUT_DIR/vehicle_damper; needs `--bushings vehicle`); `--training-seed`
trains these vehicle-derived networks from another seed (default 0). DURATION_S (default 50) shortens both systems'
drives (20 s finishes in minutes on 2 cores). The co-simulations run the master and the FMUs at their defaults.
Progress goes to stderr; the last stdout line is one JSON object: run times, the training seed, which records the
bushing and damper networks were trained on, `realtime_factor_full_vehicle` (simulated seconds per wall second of
the full vehicle with the hysteresis damper networks), the error `budget` (per system, channel and damper model:
nrmse_total, nrmse_network, nrmse_coupling, damage_ratio; see nnfmu/workflows/roadtest/budget.py), the thesis
comparison, the largest use of each network input's training envelope, and each input's share of power above the band
its training record excited (`power_above_training_band`; the record holds 1 % there).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from nnfmu.data.rigs import RigOptions, write_rig
from nnfmu.kinds import BUSHING
from nnfmu.models import get_preset
from nnfmu.workflows.demo import MOVING_MASS_BY_RIG, PRESETS_BY_RIG
from nnfmu.workflows.roadtest import (
    BushingDriveSettings,
    RoadTestSettings,
    SystemRun,
    run_road_test,
    train_vehicle_bushings,
    train_vehicle_dampers,
)
from nnfmu.workflows.train import TrainRequest, train_from_file

# The bushing preset of each channel (`BUSHING_CHANNELS` key -> preset): the one whose output is the channel's force.
BUSHING_PRESET_BY_CHANNEL = {
    c.key: next(p for p in BUSHING.presets if get_preset(p).output == c.force) for c in BUSHING.channels
}


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


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=Path("bench-out/models"), help="MODELS_DIR")
    parser.add_argument("out", nargs="?", type=Path, default=Path("bench-out/road_test"), help="OUT_DIR")
    parser.add_argument("duration", nargs="?", type=float, default=50.0, help="drive length [s]")
    parser.add_argument(
        "--bushings",
        choices=("vehicle", "lab"),
        default="vehicle",
        help="train the bushing networks on a vehicle-derived rig record, or use MODELS_DIR's",
    )
    parser.add_argument(
        "--dampers",
        choices=("vehicle", "lab"),
        default="vehicle",
        help="train the damper networks on a vehicle-derived dyno record, or use MODELS_DIR's",
    )
    parser.add_argument(
        "--training-seed",
        type=int,
        default=0,
        help="training seed of the vehicle-derived networks (their restarts' initial weights; Adam's batches)",
    )
    args = parser.parse_args()
    if args.dampers == "vehicle" and args.bushings != "vehicle":
        parser.error(
            "--dampers vehicle derives the dyno drive from the bushing step's source reference: "
            "give --bushings vehicle too"
        )
    out, duration = args.out, args.duration
    started = time.perf_counter()
    models = models_in(args.folder)
    settings = RoadTestSettings(quarter_car=SystemRun(duration), full_vehicle=SystemRun(duration))
    bushing_networks: dict[str, object] = {"trained_on": "the bushing rig's lab record"}
    if args.bushings == "vehicle":
        vehicle = train_vehicle_bushings(
            out / "vehicle_bushing",
            settings,
            BushingDriveSettings(),
            request=lambda preset: TrainRequest(preset=preset, seed=args.training_seed),
            log=log,
        )
        models |= vehicle.models
        bushing_networks = {
            "trained_on": str(vehicle.rig),
            "source_reference": str(vehicle.source),
            "seconds": {k: round(v, 1) for k, v in vehicle.seconds.items()},
        }
    damper_networks: dict[str, object] = {"trained_on": "the damper dyno's lab record"}
    if args.dampers == "vehicle":
        dampers = train_vehicle_dampers(
            vehicle.source,
            out / "vehicle_damper",
            lambda preset: TrainRequest(
                preset=preset, moving_mass=MOVING_MASS_BY_RIG["damper"], seed=args.training_seed
            ),
            log=log,
        )
        models |= dampers.models
        damper_networks = {
            "trained_on": str(dampers.rig),
            "source_reference": str(vehicle.source),
            "seconds": {k: round(v, 1) for k, v in dampers.seconds.items()},
        }
    train_seconds = time.perf_counter() - started
    result = run_road_test(out, models, settings, log=log)
    summary = json.loads(result.summary.read_text())
    envelope, above_band = {}, {}
    for system in summary["systems"]:
        for e in system["envelope"]:
            key = f"{system['system']}: {e['run']}: {e['element']}.{e['port']}"
            envelope[key] = max(envelope.get(key, 0.0), e["range_used"] or 0.0)
            if e.get("power_above_band") is not None:
                above_band[key] = {"band_edge_Hz": e["band_edge"], "power_above": e["power_above_band"]}
    full = next((s for s in summary["systems"] if s["system"] == "full-vehicle"), None)
    print(
        json.dumps(
            {
                "duration_s": duration,
                "training_seed": args.training_seed,
                "training_s": round(train_seconds, 1),
                "road_test_s": round(result.seconds, 1),
                "bushing_networks": bushing_networks,
                "damper_networks": damper_networks,
                "realtime_factor_full_vehicle": round(full["duration_s"] / full["seconds"]["damper-hysteresis"], 2)
                if full
                else None,
                "budget": [row for s in summary["systems"] for row in s["budget"]],
                "reports": {k: str(v) for k, v in result.reports().items()},
                "systems": [{k: s[k] for k in ("system", "seconds", "thesis_table")} for s in summary["systems"]],
                "largest_envelope_use": envelope,
                "power_above_training_band": above_band,
            },
            allow_nan=False,
        )
    )


if __name__ == "__main__":
    main()
