"""`nnfmu loop vehicle` on the five lab cars of issue 17, each on several drive seeds, with the outcome each must give.

Usage: python bench/vehicle_loop.py ROAD_TEST_DIR OUT [--duration 20] [--seeds 3 4 5] [--cars gas,...]

ROAD_TEST_DIR is a road test's output (`bench/road_test.py`'s OUT_DIR or `nnfmu demo`'s road_test/): its full
vehicle with the hysteresis damper networks and the LCA bushing networks (systems/full-vehicle/damper-hysteresis) is
the virtual car. Per seed a class C drive (20 m/s, that seed) and per lab car a record made from the truth physics
with the car's hidden changes (`nnfmu.workflows.roadtest.lab_car`, sensor noise 0.2 % of each channel's spread, noise
seed = drive seed); the loop runs with its default settings. The lab cars and what each must give:

- gas: undeclared gas force in damper_fr and damper_rr -> gas_force named on exactly those two; their force mean shift
  and peak-ratio error each fall by at least two thirds; the LCA angles' NRMSE no worse than before (+10 %).
- bushing: bushing_fl_front 1.5x as stiff as its rig sample -> its `stiffness` named, no damper effect; the LCA fl
  angle's NRMSE at most half of before.
- offset: +150 N zero offset of damper_fl's load cell -> sensor_offset on damper_fl_force only, no component changed.
- clean: components as trained -> nothing named.
- no-force: the gas car recorded without load cells and LVDTs (LCA angles and accelerations only) -> the effects
  named are damper effects on the right-hand corners (the family and side), and the report says what it cannot tell
  apart.

Progress goes to stderr; the last stdout line is one JSON object: per case (car, seed) the named effects, the checks
and whether they held, the key channel errors before/after and the wall time; per car the cases passed and the median
wall time.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

from nnfmu.data.drive_files import write_drive
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest import system_folder
from nnfmu.workflows.roadtest.lab_car import LAB_CHANNELS, LabCar, write_lab_car
from nnfmu.workflows.vehicle_loop import VehicleLoopReport, run_vehicle_loop

SYSTEM = "full-vehicle"
GAS = {"damper_fr": ("gas_force",), "damper_rr": ("gas_force",)}
NO_FORCE = tuple(c for c in LAB_CHANNELS[SYSTEM] if not c.startswith("damper_"))
CARS: dict[str, Callable[[int], LabCar]] = {
    "gas": lambda seed: LabCar(SYSTEM, damper_effects=GAS, seed=seed),
    "bushing": lambda seed: LabCar(SYSTEM, bushing_stiffness={"bushing_fl_front": 1.5}, seed=seed),
    "offset": lambda seed: LabCar(SYSTEM, offsets={"damper_fl_force": 150.0}, seed=seed),
    "clean": lambda seed: LabCar(SYSTEM, seed=seed),
    "no-force": lambda seed: LabCar(SYSTEM, damper_effects=GAS, channels=NO_FORCE, seed=seed),
}


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _errors(report: VehicleLoopReport, channel: str) -> dict[str, dict[str, float | None]]:
    return {when: error.to_dict() for when, error in report.channels[channel].items()}


def _nrmse(report: VehicleLoopReport, channel: str, when: str) -> float:
    return report.channels[channel][when].nrmse


def checks(car: str, report: VehicleLoopReport) -> dict[str, bool]:
    """The outcomes `car` must give (module docstring), each by name."""
    named = {(e.candidate.component, e.candidate.effect) for e in report.attribution.named}
    components = {c for c, effect in named if effect != "sensor_offset"}
    if car == "gas":
        out = {"gas_force named on damper_fr and damper_rr only": named == {(d, "gas_force") for d in GAS}}
        for d in GAS:
            before, after = report.channels[f"{d}_force"]["before"], report.channels[f"{d}_force"]["after"]
            out[f"{d} force mean shift falls by 2/3"] = abs(after.mean_shift) <= abs(before.mean_shift) / 3
            out[f"{d} force peak-ratio error falls by 2/3"] = (
                abs(after.peak_ratio - 1) <= abs(before.peak_ratio - 1) / 3
            )
        for angle in ("lca_fl_angle", "lca_fr_angle"):
            out[f"{angle} NRMSE within its error before"] = _nrmse(report, angle, "after") <= 1.1 * _nrmse(
                report, angle, "before"
            )
        return out
    if car == "bushing":
        return {
            "stiffness named on bushing_fl_front": ("bushing_fl_front", "stiffness") in named,
            "no damper effect named": not any(c.startswith("damper") for c in components),
            "lca_fl_angle NRMSE at most half of before": (
                _nrmse(report, "lca_fl_angle", "after") <= 0.5 * _nrmse(report, "lca_fl_angle", "before")
            ),
        }
    if car == "offset":
        return {
            "sensor_offset on damper_fl_force only": named == {("damper_fl_force", "sensor_offset")},
            "no component changed": not report.fixes,
        }
    if car == "clean":
        return {"nothing named": not named}
    return {
        "a damper effect named": any(c.startswith("damper") for c in components),
        "every component named is on the right-hand side": bool(components)
        and all(c.split("_")[1] in ("fr", "rr") for c in components if "_" in c),
        "the report says what it cannot tell apart": any(
            "cannot be told apart" in str(i["evidence"]) for i in report.iterations
        )
        or any("told apart" in note for note in report.coverage),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("road_test", type=Path, help="ROAD_TEST_DIR")
    parser.add_argument("out", type=Path, help="OUT")
    parser.add_argument("--duration", type=float, default=20.0, help="lab record length [s]")
    parser.add_argument("--seeds", type=int, nargs="+", default=[3, 4, 5], help="drive (and noise) seeds")
    parser.add_argument("--cars", default=",".join(CARS), help=f"comma-separated subset of {','.join(CARS)}")
    args = parser.parse_args()
    cars = [c.strip() for c in args.cars.split(",") if c.strip()]
    unknown = [c for c in cars if c not in CARS]
    if unknown:
        parser.error(f"unknown lab car(s) {unknown}; choose from {', '.join(CARS)}")
    ssd = system_folder(args.road_test, SYSTEM, "damper-hysteresis") / "SystemStructure.ssd"
    if not ssd.is_file():
        parser.error(f"{ssd} not found: ROAD_TEST_DIR must be a road test's output with the full vehicle")
    cases = []
    for seed in args.seeds:
        drive = generate_drive(DriveSettings(duration=args.duration + 0.001, seed=seed))
        drive_path = write_drive(drive, args.out / f"seed{seed}" / "drive.csv")
        for car in cars:
            folder = args.out / f"seed{seed}" / car
            started = time.perf_counter()
            record = write_lab_car(CARS[car](seed), drive, folder / "lab.csv")
            recorded = time.perf_counter() - started
            report = run_vehicle_loop(record, ssd, drive_path, folder / "loop", log=log)
            wall = time.perf_counter() - started
            found = checks(car, report)
            log(f"seed {seed} {car}: {report.summary}; checks {sum(found.values())}/{len(found)} in {wall:.0f} s")
            cases.append(
                {
                    "car": car,
                    "seed": seed,
                    "named": [f"{i['effect']} on {i['component']}" for i in report.iterations],
                    "p_values": [i["p_value"] for i in report.iterations],
                    "summary": report.summary,
                    "checks": found,
                    "passed": all(found.values()),
                    "channels": {
                        c: _errors(report, c)
                        for c in (
                            "lca_fl_angle",
                            "lca_fr_angle",
                            "damper_fl_force",
                            "damper_fr_force",
                            "damper_rr_force",
                        )
                        if c in report.channels
                    },
                    "report": str(folder / "loop" / "report.json"),
                    "record_s": round(recorded, 1),
                    "wall_s": round(wall, 1),
                }
            )
    per_car = {
        car: {
            "passed": sum(c["passed"] for c in cases if c["car"] == car),
            "cases": sum(c["car"] == car for c in cases),
            "wall_s_median": statistics.median(c["wall_s"] for c in cases if c["car"] == car),
        }
        for car in cars
    }
    print(json.dumps({"duration_s": args.duration, "seeds": args.seeds, "cars": per_car, "cases": cases}))


if __name__ == "__main__":
    main()
