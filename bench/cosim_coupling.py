"""Coupling error of the fmpy master against the monolithic solution: quarter car + linear damper FMU, steps x schemes.

Usage: python bench/cosim_coupling.py [DURATION_S]
The vehicle package's quarter-car FMU (sampled at the communication step, inputs interpolated) and a linear damper
FMU (the front damper's linear reference) on a class C drive; the reference closes the same linear damper inside
the vehicle and is solved by RK4 at 50 us with the drive linear between its samples, so every difference is the
coupling's. Compared at the instants both have. Schemes: the basic one (Gauss-Seidel, components first, nothing
estimated or refreshed: what most masters do), the default (vehicle first, linear extrapolation, refresh), the
default without the refresh, and the default iterated to a fixed point. One JSON line per step and scheme (NRMSE and
relative peak error per channel, wall time), then a summary line.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import onnx

from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.data import Measurement
from nnfmu.data.derive import derive_rates
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics import (
    LinearLaw,
    MonolithicSettings,
    QuarterCarParameters,
    build_quarter_car,
    simulate_monolithic,
)
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu, initial_state

STEPS = (0.5e-3, 1e-3, 2e-3)
SCHEMES = {
    "basic": {"order": "components-first", "extrapolation": "none", "refresh": False},
    "default": {},
    "default without refresh": {"refresh": False},
    "default iterated": {"iterations": 30, "tolerance": 1e-10},
}
CHANNELS = ("damper_force", "damper_velocity", "damper_displacement", "body_acceleration", "spindle_acceleration")


def quarter_car_drive(duration: float) -> Measurement:
    """The front-left track of a class C drive: the displacement and velocity of the post the quarter car stands on."""
    four = generate_drive(DriveSettings(duration=duration + 0.01))
    single = Measurement(
        four.time,
        {"actuator_fl_displacement": four["actuator_fl_displacement"]},
        {"actuator_fl_displacement": "m"},
        "class C drive, front left",
    )
    rates = derive_rates(single)
    return Measurement(
        rates.time,
        {k: rates[k] for k in ("actuator_fl_displacement", "actuator_fl_velocity")},
        {"actuator_fl_displacement": "m", "actuator_fl_velocity": "m/s"},
        single.source,
    )


def errors(result: Measurement, reference: dict[str, np.ndarray], period: float) -> dict[str, dict[str, float]]:
    """NRMSE (of the reference's variation) and relative peak error per channel at the instants both have."""
    k = np.round(result.time / period).astype(int)
    on_grid = np.abs(result.time - k * period) < 1e-9 * period
    found = {}
    for name in CHANNELS:
        got, want = result[name][on_grid], reference[name][k[on_grid]]
        spread = np.sqrt(np.mean((want - want.mean()) ** 2))
        found[name] = {
            "nrmse": float(np.sqrt(np.mean((got - want) ** 2)) / spread),
            "rel_peak_error": float(np.max(np.abs(got - want)) / np.max(np.abs(want))),
        }
    return found


def main() -> None:
    duration = float(sys.argv[1]) if len(sys.argv) > 1 else 5.0
    folder = Path(tempfile.mkdtemp(prefix="nnfmu-bench-coupling-"))
    drive = quarter_car_drive(duration)
    params = QuarterCarParameters.load()  # the sedan's front-left corner
    damping = params.damper.damping
    onnx.save(linear_damper_graph(damping), folder / "damper.onnx")
    damper = build_fmu(folder / "damper.onnx", BuildOptions(out=folder / "damper.fmu"))
    vehicle = build_quarter_car(params)
    started = time.perf_counter()
    exact = simulate_monolithic(
        vehicle,
        {"damper_force": LinearLaw(0.0, damping)},
        {k: drive[k] for k in drive.names},
        MonolithicSettings(sample_period=drive.sample_period, step=5e-5),
        x0=np.array(initial_state(vehicle)),
    )
    monolithic_s = time.perf_counter() - started
    table = {}
    for h in STEPS:
        car = build_vehicle_fmu("quarter-car", folder / f"car_{h:g}.fmu", VehicleBuildSettings(sample_period=h))
        ssd = write_ssd(
            connect_by_name("quarter car", ("vehicle", car), {"damper": damper}, folder), folder / f"system_{h:g}.ssd"
        )
        with open_system(ssd) as system:
            for name, kw in SCHEMES.items():
                started = time.perf_counter()
                run = cosimulate(system, drive, CosimSettings(step=h, stop_time=duration, **kw))
                row = {
                    "step_ms": h * 1e3,
                    "scheme": name,
                    "errors": errors(run.measurement, exact, drive.sample_period),
                    "mean_iterations": round(run.mean_iterations, 2),
                    "unconverged": run.unconverged_steps,
                    "wall_s": round(time.perf_counter() - started, 2),
                }
                table[(h, name)] = row
                print(json.dumps(row), flush=True)
    at_1ms = {name: {c: round(table[(1e-3, name)]["errors"][c]["nrmse"], 6) for c in CHANNELS} for name in SCHEMES}
    print(
        json.dumps(
            {
                "duration_s": duration,
                "monolithic_rk4_step_s": 5e-5,
                "monolithic_wall_s": round(monolithic_s, 1),
                "nrmse_at_1ms": at_1ms,
            }
        )
    )


if __name__ == "__main__":
    main()
