"""Wall time of the monolithic references of the road test (compiled RK4 kernel) and their agreement with the
generic per-law path (JSON, last line).

Usage: python bench/monolithic.py [DURATION_S] [REPEATS] [CHECK_S]
Both systems as `run_road_test` solves them: the ISO 8608 class C drive at 20 m/s (seed 0, 1 kHz), truth laws on
every external component, RK4 at 0.1 ms, over DURATION_S (default 50 s), REPEATS times each (default 3; median
quoted). On the first CHECK_S seconds (default 2 s) both paths run once more: their wall times give the speed-up,
and the largest difference of any channel relative to that channel's peak is reported. The kernel is compiled (or
loaded from numba's cache) by a warm-up run on 0.1 s first, and that time is reported apart.
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import time

import numpy as np

from nnfmu.data import Measurement
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest.systems import SYSTEMS, vehicle_components
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference

STEP = 1e-4  # s, the road test's reference step


def first_seconds(drive: Measurement, duration: float) -> Measurement:
    """The samples of `drive` with t <= duration (as the road test cuts its drive)."""
    n = int(np.searchsorted(drive.time, drive.time[0] + duration * (1 + 1e-12), side="right"))
    return drive.slice(0, max(n, 2))


def max_relative_difference(a: Measurement, b: Measurement) -> float:
    """Largest |a - b| of any channel over that channel's peak |b|."""
    return max(float(np.max(np.abs(a[n] - b[n])) / max(np.max(np.abs(b[n])), 1e-300)) for n in b.names)


def main() -> None:
    duration = float(sys.argv[1]) if len(sys.argv) > 1 else 50.0
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    check = float(sys.argv[3]) if len(sys.argv) > 3 else 2.0
    drive = generate_drive(DriveSettings(duration=max(duration, check) + 1e-3))
    load_before = os.getloadavg()[0]
    systems = {}
    for system in SYSTEMS:
        components = vehicle_components(system)
        started = time.perf_counter()
        monolithic_reference(system, first_seconds(drive, 0.1), components, STEP)
        warm_up = time.perf_counter() - started
        full = first_seconds(drive, duration)
        walls = [monolithic_reference(system, full, components, STEP).seconds for _ in range(repeats)]
        print(
            f"{system}: {duration:g} s in {statistics.median(walls):.2f} s (median of {walls})",
            file=sys.stderr,
            flush=True,
        )
        stretch = first_seconds(drive, check)
        compiled = monolithic_reference(system, stretch, components, STEP)
        generic = monolithic_reference(system, stretch, components, STEP, compiled=False)
        systems[system] = {
            "wall_s_median": round(statistics.median(walls), 2),
            "wall_s_runs": [round(w, 2) for w in walls],
            "warm_up_s": round(warm_up, 2),
            "check_s": check,
            "check_compiled_wall_s": round(compiled.seconds, 3),
            "check_generic_wall_s": round(generic.seconds, 2),
            "speed_up": round(generic.seconds / compiled.seconds, 1),
            "max_relative_difference": max_relative_difference(compiled.measurement, generic.measurement),
        }
    print(
        json.dumps(
            {
                "simulated_s": duration,
                "rk4_step_s": STEP,
                "repeats": repeats,
                "cpus": os.cpu_count(),
                "load_average_1min": [round(load_before, 2), round(os.getloadavg()[0], 2)],
                "systems": systems,
            }
        )
    )


if __name__ == "__main__":
    main()
