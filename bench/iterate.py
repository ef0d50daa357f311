"""`nnfmu iterate` on a quarter car with a hysteresis damper network: the issue's done-when figures (SISO).

Usage: python bench/iterate.py OUT [--damper HYST.onnx] [--duration 20] [--seed 3] [--noise 0.01]

The virtual car is the quarter car with a damper-hysteresis network FMU (trained here on a small dyno record unless
--damper gives one); the road car is the same quarter car with the damper's truth physics as an FMU. The road record:
the road car driven by a class C road at 20 m/s (that seed, faded from and back to rest; never shown to iterate),
spindle and body acceleration and damper displacement with white sensor noise of --noise x each channel's standard
deviation. `run_iterate` iterates on the virtual car with its defaults; the drive it returns is replayed by
`run_cosim` (what `nnfmu cosim` runs) on the virtual car and on the road car, each channel's NRMSE taken against the
noiseless road response. Progress to stderr; the last stdout line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from nnfmu.cosim.master import CosimSettings
from nnfmu.data import Measurement, save_measurement
from nnfmu.data.drive_files import write_drive
from nnfmu.data.rigs import RigOptions, write_rig
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.validate.metrics import nrmse
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.cosim import run_cosim
from nnfmu.workflows.iterate import IterateSettings, run_iterate
from nnfmu.workflows.iterate.signals import fade_weights
from nnfmu.workflows.roadtest.systems import build_truth_fmus, build_vehicle, write_system

H = 1e-3
TARGETS = ("spindle_acceleration", "body_acceleration", "damper_displacement")


def _log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _damper(out: Path, given: Path | None) -> Path:
    if given is not None:
        return given
    from nnfmu.workflows.train import TrainRequest, train_from_file

    dyno, _ = write_rig("damper", out / "dyno.csv", RigOptions(duration=40.0, excitation="random", noise=0.5))
    request = TrainRequest(preset="damper-hysteresis", restarts=1, max_epochs=300, hidden=(16,), moving_mass=2.0)
    return train_from_file(dyno, request, out / "hyst.onnx").path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--damper", type=Path, default=None)
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--noise", type=float, default=0.01)
    args = parser.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    onnx = _damper(out, args.damper)
    network = build_fmu(onnx, BuildOptions(out=out / "fmu" / "damper-hysteresis.fmu", platforms=("linux64",)))
    truth = build_truth_fmus(out / "truth", H, with_bushing=False).dampers["truth"]
    vehicle = build_vehicle("quarter-car", out / "fmu", H)
    virtual = write_system("quarter-car", vehicle, network, None, out / "virtual", filter_cutoff=0.0)
    road_car = write_system("quarter-car", vehicle, truth, None, out / "road-car", filter_cutoff=0.0)
    _log(f"cars built in {time.perf_counter() - started:.1f} s")

    road = generate_drive(DriveSettings(duration=args.duration, seed=args.seed))
    x = road["actuator_fl_displacement"] * fade_weights(len(road.time), H, 0.5)
    known = Measurement(
        time=road.time,
        channels={"actuator_fl_displacement": x, "actuator_fl_velocity": np.gradient(x, H)},
        units={"actuator_fl_displacement": "m", "actuator_fl_velocity": "m/s"},
        source="known road drive",
    )
    known_path = write_drive(known, out / "known-drive.csv")
    clean = run_cosim(road_car, known_path, CosimSettings(step=H)).measurement
    rng = np.random.default_rng(args.seed)
    noisy = {c: clean[c] + args.noise * np.std(clean[c]) * rng.normal(size=len(clean.time)) for c in TARGETS}
    target = save_measurement(
        Measurement(time=clean.time, channels=noisy, units={c: clean.units[c] for c in TARGETS}, source="road"),
        out / "road.csv",
    )

    began = time.perf_counter()
    result = run_iterate(target, virtual, out / "iterate", IterateSettings(), _log)
    wall = time.perf_counter() - began

    def replay(system: Path) -> dict[str, float]:
        m = run_cosim(system, result.files["drive"], CosimSettings(step=H)).measurement
        n = min(len(m.time), len(clean.time))
        return {c: round(nrmse(m[c][:n], clean[c][:n]), 5) for c in TARGETS}

    on_virtual, on_road_car = replay(virtual), replay(road_car)
    last = result.outcome.iterations[result.outcome.best]
    record = {
        "bench": "iterate",
        "case": "quarter car, damper-hysteresis network; road car with the damper's truth physics",
        "duration_s": args.duration,
        "seed": args.seed,
        "sensor_noise": args.noise,
        "iterations_played": len(result.outcome.iterations),
        "best_iteration": last.index,
        "converged": result.converged,
        "nrmse_vs_target": {c: round(m["nrmse"], 5) for c, m in last.metrics.items()},
        "pseudo_damage_ratio": {c: round(m["pseudo_damage_ratio"], 4) for c, m in last.metrics.items()},
        "replay_virtual_car_nrmse": on_virtual,
        "replay_road_car_nrmse": on_road_car,
        "targets": {"virtual": 0.05, "road_car": 0.08, "iterations": 10, "wall_s": 120.0},
        "met": {
            "virtual": max(on_virtual.values()) <= 0.05,
            "road_car": max(on_road_car.values()) <= 0.08,
            "iterations": len(result.outcome.iterations) <= 10,
            "wall": wall <= 120.0,
        },
        "iterate_wall_s": round(wall, 2),
    }
    print(json.dumps(record))


if __name__ == "__main__":
    main()
