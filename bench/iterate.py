"""`nnfmu iterate` on cars with hysteresis damper networks: the issue's done-when figures.

Usage: python bench/iterate.py OUT [--system quarter-car|full-vehicle] [--damper HYST.onnx] [--duration 20]
       [--seed 3] [--noise 0.01]

The virtual car is the quarter car (or the full vehicle, its LCA bushings the parameter file's linear ones built in)
with damper-hysteresis network FMUs (trained here on a small dyno record unless --damper gives one); the road car is
the same vehicle with the damper's truth physics as FMUs. The road record: the road car driven by a class C road at
20 m/s (that seed, faded from and back to rest; never shown to iterate), per corner spindle and body acceleration
and damper displacement (the full vehicle: 12 channels for 4 actuators) with white sensor noise of --noise x each
channel's standard deviation. `run_iterate` iterates on the virtual car with its defaults (at most 10 iterations for
the quarter car, 15 for the full vehicle); the drive it returns is replayed by `run_cosim` (what `nnfmu cosim` runs)
on the virtual car and on the road car, each channel's NRMSE and pseudo-damage ratio (Basquin slope 5) taken against
the noiseless road response. Progress to stderr; the last stdout line is one JSON object.
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
from nnfmu.validate.damage import pseudo_damage_ratio
from nnfmu.validate.metrics import nrmse
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics.ports import CORNERS
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu
from nnfmu.workflows.cosim import run_cosim
from nnfmu.workflows.iterate import IterateSettings, run_iterate
from nnfmu.workflows.iterate.signals import fade_weights
from nnfmu.workflows.roadtest.systems import build_truth_fmus, build_vehicle, bushing_elements, write_system

H = 1e-3
TARGETS = {
    "quarter-car": ("spindle_acceleration", "body_acceleration", "damper_displacement"),
    "full-vehicle": tuple(
        name
        for corner in CORNERS
        for name in (f"spindle_{corner}_acceleration", f"body_acceleration_{corner}", f"damper_{corner}_displacement")
    ),
}
ITERATIONS = {"quarter-car": 10, "full-vehicle": 15}  # the most iterations
NRMSE_TARGETS = {"quarter-car": (0.05, 0.08), "full-vehicle": (0.10, 0.10)}  # (virtual car, road car)


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
    parser.add_argument("--system", choices=sorted(TARGETS), default="quarter-car")
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
    system, targets = args.system, TARGETS[args.system]
    if system == "quarter-car":
        vehicle = build_vehicle(system, out / "fmu", H)
    else:  # dampers external, the LCA bushings the parameter file's linear elements built in
        components = {name: "reference" for name in bushing_elements(system)}
        settings = VehicleBuildSettings(components=components, sample_period=H, platforms=("linux64",))
        vehicle = build_vehicle_fmu(system, out / "fmu" / f"{system}.fmu", settings)
    virtual = write_system(system, vehicle, network, None, out / "virtual", filter_cutoff=0.0)
    road_car = write_system(system, vehicle, truth, None, out / "road-car", filter_cutoff=0.0)
    _log(f"cars built in {time.perf_counter() - started:.1f} s")

    road = generate_drive(DriveSettings(duration=args.duration, seed=args.seed))
    fade = fade_weights(len(road.time), H, 0.5)
    channels, units = {}, {}
    for corner in CORNERS if system == "full-vehicle" else ("fl",):
        x = road[f"actuator_{corner}_displacement"] * fade
        channels |= {f"actuator_{corner}_displacement": x, f"actuator_{corner}_velocity": np.gradient(x, H)}
        units |= {f"actuator_{corner}_displacement": "m", f"actuator_{corner}_velocity": "m/s"}
    known = Measurement(time=road.time, channels=channels, units=units, source="known road drive")
    known_path = write_drive(known, out / "known-drive.csv")
    clean = run_cosim(road_car, known_path, CosimSettings(step=H)).measurement
    rng = np.random.default_rng(args.seed)
    noisy = {c: clean[c] + args.noise * np.std(clean[c]) * rng.normal(size=len(clean.time)) for c in targets}
    target = save_measurement(
        Measurement(time=clean.time, channels=noisy, units={c: clean.units[c] for c in targets}, source="road"),
        out / "road.csv",
    )

    began = time.perf_counter()
    result = run_iterate(target, virtual, out / "iterate", IterateSettings(iterations=ITERATIONS[system]), _log)
    wall = time.perf_counter() - began

    def replay(car: Path) -> tuple[dict[str, float], dict[str, float]]:
        m = run_cosim(car, result.files["drive"], CosimSettings(step=H)).measurement
        n = min(len(m.time), len(clean.time))
        return (
            {c: round(nrmse(m[c][:n], clean[c][:n]), 5) for c in targets},
            {c: round(pseudo_damage_ratio(m[c][:n], clean[c][:n], 5.0), 4) for c in targets},
        )

    (on_virtual, damage_virtual), (on_road_car, damage_road_car) = replay(virtual), replay(road_car)
    limit_virtual, limit_road = NRMSE_TARGETS[system]
    last = result.outcome.iterations[result.outcome.best]
    record = {
        "bench": "iterate",
        "case": f"{system}, damper-hysteresis networks; road car with the damper's truth physics",
        "system": system,
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
        "replay_virtual_car_pseudo_damage_ratio": damage_virtual,
        "replay_road_car_pseudo_damage_ratio": damage_road_car,
        "targets": {
            "virtual": limit_virtual,
            "road_car": limit_road,
            "iterations": ITERATIONS[system],
            "wall_s": 120.0,
            "pseudo_damage_ratio": [0.8, 1.25],
        },
        "met": {
            "virtual": max(on_virtual.values()) <= limit_virtual,
            "road_car": max(on_road_car.values()) <= limit_road,
            "iterations": len(result.outcome.iterations) <= ITERATIONS[system],
            "wall": wall <= 120.0,
            "pseudo_damage_ratio": all(0.8 <= r <= 1.25 for r in damage_virtual.values()),
        },
        "iterate_wall_s": round(wall, 2),
    }
    print(json.dumps(record))


if __name__ == "__main__":
    main()
