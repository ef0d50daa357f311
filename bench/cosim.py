"""Speed of the fmpy co-simulation master: 50 s of road excitation at a 1 ms communication step (one JSON line).

Usage: python bench/cosim.py [MODELS_DIR] [DURATION_S] [REPEATS]
Systems as the road test builds them (`nnfmu.workflows.roadtest.systems`): the quarter car with a damper network (2
FMUs) and the full vehicle with four damper networks and its four front LCA bushing networks on stabilised ports (9
FMUs), the vehicle FMU sampled at the communication step, the master's default coupling (its compiled inner loop where a
C compiler is found), network FMUs at their default parameters (output filter off). MODELS_DIR holds
<preset>.onnx of the two damper and four bushing presets; without it, the presets are trained in a temporary folder on
short rig records with short training (the networks' size and graph are the presets', their accuracy is not quoted).
Preparation (training, FMU builds) is not timed. Timed: the whole `cosimulate` call (instantiation, initialisation,
the run, teardown), the median of REPEATS runs; `loop_s` is the stepping alone. Whether the full vehicle stayed
bounded: every channel finite, and the peaks of its motion channels within BOUNDED_RATIO of a run of the same system
with the parameter file's linear bushings built in instead of the networks. Progress goes to stderr; stdout gets one
JSON object on one line (targets: full vehicle <= 2.5 s (20x real time, issue #14), quarter car <= 1 s for 50 s).

The compiled engine (`compiled_*`): each system built into one system FMU (`nnfmu system build`, inner step = the
1 ms step; the build is not timed) and stepped at 1 ms by a master in C (bench/system_fmu_driver.c: per step the
drive, its slopes, doStep, every output), timed from loading the FMU's library to closing it (instantiation
included); `compiled_*_matches_master` is the largest difference of any output from the Python master's run,
relative to its peak (targets of issue 33: full vehicle >= 200x real time, quarter car >= 1000x).

`nnfmu cosim --engine compiled` (`engine_compiled_*`): the whole `cosimulate_compiled` call, the same system FMU
(cached: the first call builds it, `first_wall_s`, in this process's cache folder) opened by fmpy and stepped from C
(templates/c/system_loop.c); `matches_master` as above.

`bushing_network_passivity`: the bushing networks' sine tests in which a channel gives energy back
(`nnfmu.workflows.passivity`); with such a network (the demo's lab-trained radial one) the full vehicle's radial
bushing channels are chaotic, so `matches_master` there measures rounding amplified, not the engines
(docs/passivity.md).
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
import onnx
from fmpy import read_model_description
from road_test import models_in  # bench/ is on the path when a bench script runs

from nnfmu.cosim.container.build import build_system_fmu
from nnfmu.cosim.drive_inputs import DriveInputs
from nnfmu.cosim.master import CosimError, CosimSettings, cosimulate
from nnfmu.cosim.ssp import open_system, read_ssd
from nnfmu.data import Measurement
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics.components import REFERENCE
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu
from nnfmu.workflows.passivity import passivity_warnings
from nnfmu.workflows.roadtest.systems import build_component_fmus, build_vehicle, bushing_elements, write_system

STEP = 1e-3  # [s] communication step
DAMPER = "damper-hysteresis"
QUICK_RECORDS = {"damper": 40.0, "bushing": 40.0}  # [s] rig records for the quick networks
QUICK_TRAINING = {"restarts": 1, "max_epochs": 15}
# [s] for 50 s simulated (full vehicle: 20x real time)
TARGETS = {"full_vehicle_wall_s": 2.5, "quarter_car_wall_s": 1.0}
COMPILED_TARGETS = {"compiled_full_vehicle_wall_s": 50.0 / 200.0, "compiled_quarter_car_wall_s": 50.0 / 1000.0}
MOTION_CHANNELS = (
    "body_heave",
    "body_pitch",
    "lca_fl_angle",
    "damper_fl_displacement",
    "bushing_fl_front_axial_displacement",
    "bushing_fl_front_radial_displacement",
)
BOUNDED_RATIO = 10.0  # a diverging loop grows by orders of magnitude; a stable one stays within tens of percent


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def linear_bushing_vehicle(out: Path) -> Path:
    """The full vehicle with the parameter file's linear LCA bushings built in (the boundedness yardstick)."""
    components = {name: REFERENCE for name in bushing_elements("full-vehicle")}
    return build_vehicle_fmu(
        "full-vehicle",
        out / "full-vehicle-linear-bushings.fmu",
        VehicleBuildSettings(components=components, sample_period=STEP),
    )


def timed_runs(
    ssd: Path, drive: Measurement, duration: float, repeats: int
) -> tuple[list[float], list[float], Measurement | None, str]:
    """(wall times [s] of whole runs, their stepping times [s], the last result, error text or '')."""
    walls, loops, result = [], [], None
    settings = CosimSettings(step=STEP, stop_time=duration)
    for _ in range(repeats):
        with open_system(ssd) as system:
            started = time.perf_counter()
            try:
                result = cosimulate(system, drive, settings).measurement
            except CosimError as error:  # a diverging loop: an FMU refuses a non-finite input
                return walls + [time.perf_counter() - started], loops, None, str(error)
            walls.append(time.perf_counter() - started)
            loops.append(float(result.notes["wall_time_s"]))
    return walls, loops, result, ""


def compiled_driver(folder: Path) -> Path:
    """bench/system_fmu_driver.c compiled with the host compiler (-O2) into `folder`."""
    from nnfmu.fmu.native.backend import fmi_headers_dir

    driver = folder / "system_fmu_driver"
    source = Path(__file__).with_name("system_fmu_driver.c")
    command = ["cc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-Wvla", f"-I{fmi_headers_dir()}"]
    subprocess.run([*command, "-o", str(driver), str(source), "-ldl"], check=True)
    return driver


def compiled_runs(
    ssd: Path, drive: Measurement, duration: float, repeats: int, folder: Path, reference: Measurement | None
) -> dict:
    """The system FMU of `ssd` stepped at STEP by a C master (bench/system_fmu_driver.c): per run the seconds from
    loading the FMU's library to closing it (instantiation included) and of the stepping loop, and the largest
    difference of any output from the Python master's `reference`, relative to its peak."""
    fmu = folder / f"{ssd.parent.name}-system.fmu"
    with open_system(ssd) as system:
        build_system_fmu(system, fmu, STEP, None, CosimSettings(port_derivatives=False))
    unpacked = folder / f"{ssd.parent.name}-system"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unpacked)
    description = read_model_description(str(fmu))
    names = [v.name for v in description.modelVariables if v.causality == "input"]
    outputs = [v.name for v in description.modelVariables if v.causality == "output"]
    n = round(duration / STEP)
    drive_file, out_file = folder / "drive.bin", folder / "outputs.bin"
    DriveInputs(drive, names).table(np.arange(n + 1) * STEP).astype(np.float64).tofile(drive_file)
    library = unpacked / "binaries" / "linux64" / f"{description.coSimulation.modelIdentifier}.so"
    command = [str(compiled_driver(folder)), str(library), description.guid, (unpacked / "resources").as_uri()]
    command += [str(len(names)), str(len(outputs)), str(n), repr(STEP), str(drive_file), str(out_file)]
    walls, loops = [], []
    for _ in range(repeats):
        done = subprocess.run(command, capture_output=True, text=True, check=True)
        loop, whole = map(float, done.stdout.split())
        walls.append(whole)
        loops.append(loop)
    table = np.fromfile(out_file).reshape(n + 1, len(outputs))
    record = {"wall_s": [round(w, 3) for w in walls], "median_wall_s": round(statistics.median(walls), 3)}
    record["median_loop_s"] = round(statistics.median(loops), 3)
    record["real_time_factor"] = round(duration / record["median_wall_s"], 1)
    if reference is not None:
        errors = {
            c: float(np.max(np.abs(table[:, i] - reference[c])) / max(float(np.max(np.abs(reference[c]))), 1e-300))
            for i, c in enumerate(outputs)
        }
        worst = max(errors, key=errors.get)
        record["matches_master"] = {"largest_relative_difference": errors[worst], "channel": worst}
    return record


def engine_runs(ssd: Path, drive: Measurement, duration: float, repeats: int, reference: Measurement | None) -> dict:
    """`cosimulate_compiled` on `ssd`: the first call (the system FMU built, unless cached before) and the median of
    `repeats` more (cached), whole calls; the largest difference of any output from the Python master's run."""
    from nnfmu.cosim.container.engine import cosimulate_compiled

    settings = CosimSettings(step=STEP, stop_time=duration, port_derivatives=False)
    walls, result = [], None
    with open_system(ssd) as system:
        for _ in range(repeats + 1):
            started = time.perf_counter()
            result = cosimulate_compiled(system, drive, settings).measurement
            walls.append(time.perf_counter() - started)
    record = {"first_wall_s": round(walls[0], 3), "wall_s": [round(w, 3) for w in walls[1:]]}
    record["median_wall_s"] = round(statistics.median(walls[1:]), 3)
    record["median_loop_s"] = float(result.notes["wall_time_s"])
    record["real_time_factor"] = round(duration / record["median_wall_s"], 1)
    if reference is not None:
        errors = {
            c: float(np.max(np.abs(result[c] - reference[c])) / max(float(np.max(np.abs(reference[c]))), 1e-300))
            for c in reference.names
        }
        worst = max(errors, key=errors.get)
        record["matches_master"] = {"largest_relative_difference": errors[worst], "channel": worst}
    return record


def summary(name: str, fmus: int, walls: list[float], loops: list[float], duration: float, error: str) -> dict:
    """One system's timings: every run, medians, real-time factor (None if the run failed) and the error text."""
    wall = statistics.median(walls)
    record = {
        "system": name,
        "fmus": fmus,
        "wall_s": [round(w, 3) for w in walls],
        "median_wall_s": round(wall, 3),
        "median_loop_s": round(statistics.median(loops), 3) if loops else None,
        "real_time_factor": round(duration / wall, 2) if not error else None,
    }
    return record | ({"error": error} if error else {})


def boundedness(result: Measurement | None, yardstick: Measurement) -> dict:
    """All channels finite, and each motion channel's peak against the linear-bushing run's."""
    if result is None:
        return {"bounded": False}
    finite = all(bool(np.all(np.isfinite(result[c]))) for c in result.names)
    ratios = {c: float(np.max(np.abs(result[c])) / np.max(np.abs(yardstick[c]))) for c in MOTION_CHANNELS}
    largest = max(result.names, key=lambda c: float(np.max(np.abs(result[c]))))
    return {
        "bounded": finite and all(r < BOUNDED_RATIO for r in ratios.values()),
        "all_finite": finite,
        "peak_ratio_to_linear_bushings": {c: round(r, 3) for c, r in ratios.items()},
        "largest_channel": f"{largest} [{result.units[largest]}]",
        "largest_abs_value": float(np.max(np.abs(result[largest]))),
    }


def met(records: dict[str, dict], duration: float) -> dict[str, bool]:
    """Whether each system ran without error within its target, scaled to the simulated duration."""
    return {
        key: "error" not in records[system] and records[system]["median_wall_s"] <= limit * duration / 50.0
        for key, system, limit in (
            ("full_vehicle_wall_s", "full-vehicle", TARGETS["full_vehicle_wall_s"]),
            ("quarter_car_wall_s", "quarter-car", TARGETS["quarter_car_wall_s"]),
        )
    }


def main() -> None:
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 50.0
    repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    with tempfile.TemporaryDirectory(prefix="nnfmu-bench-cosim-") as scratch:
        work = Path(scratch)
        prepared = time.perf_counter()
        models = models_in(Path(sys.argv[1]) if len(sys.argv) > 1 else work / "models", QUICK_RECORDS, **QUICK_TRAINING)
        fmus = build_component_fmus(models, work / "fmu", with_bushing=True)
        passivity = passivity_warnings("lca-bushing", onnx.load(work / "fmu" / "lca-bushing.onnx"))
        for line in passivity:
            log(f"warning: {line}")
        drive = generate_drive(DriveSettings(duration=duration + STEP))
        ssds = {
            system: write_system(
                system,
                build_vehicle(system, work / "fmu", STEP),
                fmus.dampers[DAMPER],
                fmus.bushing if bushing_elements(system) else None,
                work / system,
            )
            for system in ("quarter-car", "full-vehicle")
        }
        linear = write_system(
            "full-vehicle",
            linear_bushing_vehicle(work / "fmu"),
            fmus.dampers[DAMPER],
            None,
            work / "full-vehicle-linear-bushings",
        )
        log(f"prepared in {time.perf_counter() - prepared:.1f} s")
        load = os.getloadavg()[0]  # other work on the machine slows the timed runs
        records, results = {}, {}
        for system, ssd in ssds.items():
            walls, loops, results[system], error = timed_runs(ssd, drive, duration, repeats)
            records[system] = summary(system, len(read_ssd(ssd).elements), walls, loops, duration, error)
            log(json.dumps(records[system]))
        compiled = {}
        for system, ssd in ssds.items():
            compiled[system] = compiled_runs(ssd, drive, duration, repeats, work, results[system])
            log(json.dumps({"compiled": system} | compiled[system]))
        engine = {}
        for system, ssd in ssds.items():
            engine[system] = engine_runs(ssd, drive, duration, repeats, results[system])
            log(json.dumps({"engine_compiled": system} | engine[system]))
        _, _, yardstick, error = timed_runs(linear, drive, duration, 1)
        if yardstick is None:
            raise SystemExit(f"the linear-bushing yardstick run failed: {error}")
    full, quarter = records["full-vehicle"], records["quarter-car"]
    print(
        json.dumps(
            {
                "simulated_s": duration,
                "step_s": STEP,
                "steps": round(duration / STEP),
                "repeats": repeats,
                "full_vehicle_wall_s": full["median_wall_s"],
                "quarter_car_wall_s": quarter["median_wall_s"],
                "compiled_full_vehicle_wall_s": compiled["full-vehicle"]["median_wall_s"],
                "compiled_quarter_car_wall_s": compiled["quarter-car"]["median_wall_s"],
                "compiled_full_vehicle_matches_master": compiled["full-vehicle"].get("matches_master"),
                "compiled_quarter_car_matches_master": compiled["quarter-car"].get("matches_master"),
                "compiled": compiled,
                "engine_compiled_full_vehicle_wall_s": engine["full-vehicle"]["median_wall_s"],
                "engine_compiled_quarter_car_wall_s": engine["quarter-car"]["median_wall_s"],
                "engine_compiled": engine,
                "compiled_targets_s": COMPILED_TARGETS,
                "real_time_factor": {
                    "full_vehicle": full["real_time_factor"],
                    "quarter_car": quarter["real_time_factor"],
                },
                "fmus": {"full_vehicle": full["fmus"], "quarter_car": quarter["fmus"]},
                "targets_s": TARGETS,
                "targets_met": met(records, duration),
                "full_vehicle_stability": boundedness(results["full-vehicle"], yardstick),
                "bushing_network_passivity": passivity or "passive in every sine test (docs/passivity.md)",
                "systems": records,
                "setup": {
                    "scheme": "the master's defaults (vehicle first, linear extrapolation, refresh)",
                    "inner_loop": results["full-vehicle"].notes.get("inner_loop") if results["full-vehicle"] else None,
                    "vehicle_sample_period_s": STEP,
                    "damper_network": DAMPER,
                    "bushings": "network FMUs on stabilised vehicle ports",
                    "network_output_filter": "FMU default (off)",
                    "models": sys.argv[1] if len(sys.argv) > 1 else "quick-trained (bench)",
                    "cpus": os.cpu_count(),
                    "load_average_1min_before_runs": round(load, 2),
                    "python": platform.python_version(),
                    "machine": platform.machine(),
                },
            },
            allow_nan=False,
        )
    )


if __name__ == "__main__":
    main()
