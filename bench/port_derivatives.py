"""Coupling budget of the full vehicle's stabilised bushing ports with fitted elements vs per-step derivatives.

Usage: python bench/port_derivatives.py [OUT_DIR] [DURATION_S] [STEP_S]
The road test's coupling-only runs, trained nothing: the truth physics as FMUs in the networks' place
(`build_truth_fmus`) on the full vehicle with its front LCA bushings on stabilised ports, against the monolithic
reference (truth physics, RK4 at 0.1 ms) on the road test's drive (class C, 20 m/s, seed 0, 0.5 s fade-in), DURATION_S
(default 10) at STEP_S (default 1 ms). The ports' elements are fitted once as the road test fits them to its networks
(`incremental_element`: dF = k dx + c dv between consecutive samples), here to the truth bushing graph along the
front-left front bushing's motion in a reference on another drive seed (1). Runs:
- `fitted`: the vehicle as the road test builds it (fitted elements, no derivative inputs);
- `fitted, derivative inputs unset`: the vehicle with derivative inputs, the master told not to set them (must equal
  `fitted` bit for bit);
- `derivatives`: the same vehicle, the master setting every port's stiffness each step from the truth bushing FMU's
  directional derivatives (the truth graph reads no rates, so the damping inputs get 0).
Per run the NRMSE of the road test's compared channels against the reference (the budget's `nrmse_coupling`),
wall and CPU time. Progress to stderr; the last stdout line is one JSON object.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import onnx

from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import open_system
from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.export.step_runner import run_step_graph
from nnfmu.validate import ValidationSettings, compare
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest.runs import COMPARED
from nnfmu.workflows.roadtest.stabilisers import incremental_element
from nnfmu.workflows.roadtest.systems import (
    build_truth_fmus,
    build_vehicle,
    bushing_elements,
    vehicle_components,
    write_system,
)
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference
from nnfmu.workflows.vehicle_binding import vehicle_binding

SYSTEM = "full-vehicle"
FIT_ELEMENT = "bushing_fl_front"


def log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def drive(seed: int, duration: float):
    return generate_drive(DriveSettings(road_class="C", speed=20.0, seed=seed, duration=duration + 1e-3, fade_in=0.5))


def fitted_elements(truth_onnx: Path, duration: float) -> dict[str, tuple[float, float]]:
    """(k, c) per stabilised bushing port, fitted to the truth bushing graph along another seed's bushing motion."""
    motion = monolithic_reference(SYSTEM, drive(1, duration), vehicle_components(SYSTEM)).measurement
    graph = onnx.load(truth_onnx)
    inputs = {c.position: motion[f"{FIT_ELEMENT}_{c.position}"] for c in BUSHING_CHANNELS.values()}
    forces = run_step_graph(graph, inputs)
    fitted = {}
    for channel in BUSHING_CHANNELS.values():
        element = incremental_element(
            inputs[channel.position], motion[f"{FIT_ELEMENT}_{channel.rate}"], forces[channel.force]
        )
        if element is not None:
            fitted[channel.force] = element
    return {f"{name}_{force}": value for name in bushing_elements(SYSTEM) for force, value in fitted.items()}


def run(ssd: Path, road, step: float, duration: float, derivatives: bool) -> tuple[object, float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    with open_system(ssd) as system:
        settings = CosimSettings(step=step, stop_time=duration, port_derivatives=derivatives)
        result = cosimulate(system, road, settings, binding=vehicle_binding(system))
    return result.measurement, time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("/tmp/nnfmu-bench-port-derivatives")
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 10.0
    step = float(sys.argv[3]) if len(sys.argv) > 3 else 1e-3
    out.mkdir(parents=True, exist_ok=True)
    truth = build_truth_fmus(out / "fmu", 1e-3, with_bushing=True)
    assert truth.bushing is not None
    started = time.perf_counter()
    stabilisers = fitted_elements(out / "fmu" / "truth-bushing.onnx", min(duration, 10.0))
    log(f"fitted elements in {time.perf_counter() - started:.1f} s: {stabilisers}")
    road = drive(0, duration)
    started = time.perf_counter()
    reference = monolithic_reference(SYSTEM, road, vehicle_components(SYSTEM)).measurement
    log(f"reference in {time.perf_counter() - started:.1f} s")
    vehicles = {
        "plain": build_vehicle(SYSTEM, out / "plain", step, stabilisers),
        "inputs": build_vehicle(SYSTEM, out / "inputs", step, stabilisers, port_derivatives=True),
    }
    ssds = {
        name: write_system(SYSTEM, fmu, truth.dampers["truth"], truth.bushing, out / f"system-{name}")
        for name, fmu in vehicles.items()
    }
    channels = list(COMPARED[SYSTEM])
    runs = {
        "fitted": (ssds["plain"], False),
        "fitted, derivative inputs unset": (ssds["inputs"], False),
        "derivatives": (ssds["inputs"], True),
    }
    results, rows = {}, {}
    for name, (ssd, derivatives) in runs.items():
        measurement, wall, cpu = run(ssd, road, step, duration, derivatives)
        results[name] = measurement
        found = compare(measurement, reference, channels, ValidationSettings())
        rows[name] = {
            "nrmse_coupling": {c.name: round(float(c.metrics.nrmse), 6) for c in found},
            "wall_s": round(wall, 1),
            "cpu_s": round(cpu, 1),
            "inner_loop": measurement.notes.get("inner_loop"),
        }
        log(f"{name}: {json.dumps(rows[name])}")
    same = all(np.array_equal(results["fitted"][c], results["fitted, derivative inputs unset"][c]) for c in channels)
    print(
        json.dumps(
            {
                "system": SYSTEM,
                "duration_s": duration,
                "step_s": step,
                "drive": "ISO 8608 class C, 20 m/s, seed 0, fade-in 0.5 s",
                "reference": "monolithic RK4 at 1e-4 s, truth physics",
                "elements_fitted_to": f"truth bushing graph along {FIT_ELEMENT}'s motion, drive seed 1",
                "stabilisers": {k: [round(v, 3) for v in value] for k, value in stabilisers.items()},
                "unset_inputs_bit_identical": bool(same),
                "runs": rows,
                "load_average": [round(v, 2) for v in os.getloadavg()],
            }
        )
    )


if __name__ == "__main__":
    main()
