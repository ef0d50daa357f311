"""Example: a semi-active quarter car in closed loop with a skyhook controller, against the same damper held soft
and hard, on a generated road.

Usage: python examples/semiactive/run_closed_loop.py [--damper DAMPER.fmu] [--out DIR] [--duration 30] [--seed 0]
       [--road-class C] [--speed 20] [--c-sky 3000] [--c-min 1000] [--c-max 4000] [--command voltage|current]
       [--command-min V] [--command-max V] [--json RESULT.json]

Builds into DIR (default out/semiactive): the packaged sedan's front-left quarter car as a vehicle FMU (damper as a
port), the damper (--damper: any damper FMU with `velocity` [m/s] and a command input `voltage` [V] or `current` [A],
e.g. a trained `damper-semiactive` network, whose displacement input, if any, is wired too; default: the analytic
damper F = (c0 + c1·u_f)·v of `nnfmu.export.semiactive_damper`, 1-4 kN.s/m over 0-5 V with a 5.3 ms coil lag), the
skyhook controller and two fixed-command controllers (soft: --command-min, hard: --command-max), one SSP system per
controller (`nnfmu.workflows.controller.write_closed_loop`), and a class C drive. Each system is co-simulated with
the fmpy master's default scheme; the skyhook loop again with fmpy and libcosim on the Jacobi scheme they share, as
a cross-check. Prints the body-acceleration RMS and the other ride numbers as a markdown table, and last a JSON line.
--c-min/--c-max must be the damping the damper gives at --command-min/--command-max: the defaults are the analytic
damper's; for a trained network read them off its rig record.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
from fmpy import read_model_description

from nnfmu.atomic import write_text_atomic
from nnfmu.cosim.master import CosimSettings
from nnfmu.data.drive_files import write_drive
from nnfmu.export.semiactive_damper import semiactive_damper_graph
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.fmu import build_vehicle_fmu
from nnfmu.workflows.controller import (
    SkyhookSettings,
    build_fixed_command_fmu,
    build_graph_fmu,
    build_skyhook_fmu,
    known_command,
    write_closed_loop,
)
from nnfmu.workflows.cosim import run_cosim

STEP = 1e-3  # [s] communication step: the controller's and the analytic damper's sample period
JACOBI = CosimSettings(step=STEP, scheme="jacobi", extrapolation="none", refresh=False)  # libcosim's algorithm


def _command_input(damper: Path) -> str:
    """The damper FMU's command input: its one Real input besides the stroke's velocity and displacement."""
    inputs = [
        v.name
        for v in read_model_description(str(damper)).modelVariables
        if v.causality == "input" and v.name not in ("velocity", "displacement")
    ]
    if len(inputs) != 1:
        raise SystemExit(
            f"{damper}: expected one command input besides velocity/displacement, found {inputs}; give --command"
        )
    return inputs[0]


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _ride(result: Any, command: str) -> dict[str, float]:
    """Ride comfort, road holding and travel of one run (SI units)."""
    m = result.measurement
    return {
        "body_acceleration_rms": _rms(m["body_acceleration"]),
        "tyre_force_std": float(np.std(m["spindle_vertical_force"])),
        "damper_stroke_std": float(np.std(m["damper_displacement"])),
        "mean_command": float(np.mean(m[f"controller_{command}"])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--damper", type=Path, help="damper FMU with a command input (default: the analytic damper)")
    parser.add_argument("--out", type=Path, default=Path("out/semiactive"))
    parser.add_argument("--duration", type=float, default=30.0, help="drive duration [s]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--road-class", default="C")
    parser.add_argument("--speed", type=float, default=20.0, help="[m/s]")
    parser.add_argument("--c-sky", type=float, default=SkyhookSettings.c_sky, help="[N.s/m]")
    parser.add_argument("--c-min", type=float, default=SkyhookSettings.c_min, help="[N.s/m] at --command-min")
    parser.add_argument("--c-max", type=float, default=SkyhookSettings.c_max, help="[N.s/m] at --command-max")
    parser.add_argument("--command", choices=("voltage", "current"), help="default: the damper FMU's command input")
    parser.add_argument("--command-min", type=float, help="soft command (default: 0 V or 0.3 A)")
    parser.add_argument("--command-max", type=float, help="hard command (default: 5 V or 1.8 A)")
    parser.add_argument("--json", type=Path, help="write the summary there too")
    args = parser.parse_args()

    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    damper = args.damper
    if damper is None:
        damper = build_graph_fmu(
            semiactive_damper_graph(
                command=args.command or "voltage", unit=known_command(args.command or "voltage").unit
            ),
            out / "analytic_damper.fmu",
        )
    command = known_command(args.command or _command_input(damper), args.command_min, args.command_max)
    vehicle = build_vehicle_fmu("quarter-car", out / "quarter_car.fmu")
    settings = SkyhookSettings(c_sky=args.c_sky, c_min=args.c_min, c_max=args.c_max, command=command)
    controllers = {
        "skyhook": build_skyhook_fmu(settings, out / "skyhook.fmu"),
        "soft": build_fixed_command_fmu(command, command.soft, out / "soft.fmu"),
        "hard": build_fixed_command_fmu(command, command.hard, out / "hard.fmu"),
    }
    drive_settings = DriveSettings(
        road_class=args.road_class, speed=args.speed, duration=args.duration, seed=args.seed, fade_in=1.0
    )
    drive = write_drive(generate_drive(drive_settings), out / "drive.csv")
    rides, systems = {}, {}
    for name, controller in controllers.items():
        (out / name).mkdir(exist_ok=True)
        systems[name] = write_closed_loop(out / name, vehicle, damper, controller)
        rides[name] = _ride(
            run_cosim(systems[name], drive, CosimSettings(step=STEP), out / f"{name}.csv"), command.name
        )
    fmpy = run_cosim(systems["skyhook"], drive, JACOBI).measurement
    libcosim = run_cosim(systems["skyhook"], drive, JACOBI, master="libcosim").measurement
    cross = max(
        float(np.max(np.abs(libcosim[n] - fmpy[n])) / max(float(np.max(np.abs(fmpy[n]))), 1e-300)) for n in fmpy.names
    )

    print(
        f"| controller | body acceleration RMS [m/s^2] | tyre force std [N] | stroke std [mm] | mean {command.name} "
        f"[{command.unit}] |"
    )
    print("|---|---|---|---|---|")
    for name, ride in rides.items():
        print(
            f"| {name} | {ride['body_acceleration_rms']:.3f} | {ride['tyre_force_std']:.0f} | "
            f"{1e3 * ride['damper_stroke_std']:.2f} | {ride['mean_command']:.2f} |"
        )
    print(f"fmpy vs libcosim (Jacobi, skyhook loop): largest difference {cross:.1e} of a channel's peak")
    summary = {
        "damper": str(damper),
        "command": command.name,
        "drive": {
            "road_class": args.road_class,
            "speed_m_s": args.speed,
            "duration_s": args.duration,
            "seed": args.seed,
        },
        "settings": {
            "c_sky": settings.c_sky,
            "c_min": settings.c_min,
            "c_max": settings.c_max,
            "command_soft": command.soft,
            "command_hard": command.hard,
        },
        "ride": rides,
        "skyhook_vs_soft_body_acceleration": rides["skyhook"]["body_acceleration_rms"]
        / rides["soft"]["body_acceleration_rms"],
        "fmpy_vs_libcosim_max_relative_difference": cross,
    }
    if args.json:
        write_text_atomic(args.json, json.dumps(summary, indent=2) + "\n")
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
