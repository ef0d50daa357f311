"""The full vehicle's system FMU in a plain fmpy loop at H = 1 ms against the monolithic reference (one JSON line).

Usage: python bench/container_plain.py [MODELS_DIR] [DURATION_S]
Issue 33's accuracy check of the container (`nnfmu system build SSD --out car.fmu --step 1e-3 --inner-step 1e-4`):
the full vehicle with its 4 damper-hysteresis and 4 front LCA bushing networks wired as the road test wires them
(`nnfmu.workflows.roadtest.systems`: bushings on stabilised ports, stabilisers fitted to the bushing networks), the
vehicle FMU sampling at 0.1 ms (the inner step must be a multiple of its sample period), built into one system FMU
with inner step h = 0.1 ms. It runs in two plain masters that know nothing of nnfmu: a hand loop over fmpy's
`FMU2Slave` (instantiate, drive set at t_n, doStep(t_n, H), outputs read; no input derivatives) and fmpy's
`simulate_fmu` (no input derivatives). The reference is the monolithic full vehicle with the truth laws (RK4 at
0.1 ms, `monolithic_reference`, as the road test's) on the same drive (ISO 8608 class C at 20 m/s, seed 0, faded
in over 0.5 s, the road test's drive generator). The networks' own error is the road test's `nrmse_network`
(`nnfmu.workflows.roadtest.budget`, computed by the road test's own `network_errors`): a damper network's FMU
replayed open loop on the reference's own motion of its damper against the reference's truth-law force; for a
body acceleration, the co-simulation with the networks against the one with the truth laws as FMUs, both on nnfmu's
master at 1 ms as in the road test. Reported per damper force (4) and body acceleration (4 corners, heave, roll,
pitch): NRMSE against the reference of the container at h = 0.1 ms in each plain master, the networks' own error,
the ratio (issue 33: <= 1.5); the same container at h = 1 ms (before sub-stepping); the truth laws as FMUs in the
networks' places in the container at both inner steps (the coupling's share); the road test's own co-simulation
(nnfmu's master at 1 ms); and, to split the error, the container at h = 0.1 ms given the drive's slopes
(the hand loop setting fmi2SetRealInputDerivatives: the drive linear over each step instead of extrapolated from
the step before; fmpy 0.3.32's `simulate_fmu(set_input_derivatives=True)` fails on 8 inputs, its buffer holds 9
values), with the drive held (`--hold-drive`), and with one kind of network at a time, the truth law in the other's
places (`split_by_network_h_0.1ms`). MODELS_DIR's networks decide the outcome: bushing networks that oscillate with
the arm at a 0.1 ms exchange show here as body accelerations far beyond their own error (docs/system-fmu.md).

MODELS_DIR holds <preset>.onnx of the two damper and four bushing presets (e.g. a demo's vehicle-trained networks);
without it, the presets are trained in a temporary folder on short rig records with short training (`bench/cosim.py`
does the same; their accuracy is poorer, which makes the ratio easier). DURATION_S: drive length [s] (default 10).
Progress goes to stderr; stdout's last line is one JSON object.
"""

from __future__ import annotations

import json
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import onnx
from fmpy import simulate_fmu
from road_test import models_in  # bench/ is on the path when a bench script runs

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "cosim"))  # the plain loop, test-made
from plain_master import plain_run, port_names  # noqa: E402

from nnfmu.cosim.container.build import build_system_fmu  # noqa: E402
from nnfmu.cosim.drive_inputs import DriveInputs  # noqa: E402
from nnfmu.cosim.master import CosimSettings, cosimulate  # noqa: E402
from nnfmu.cosim.ssp import open_system  # noqa: E402
from nnfmu.data import Measurement  # noqa: E402
from nnfmu.validate import ValidationSettings, compare  # noqa: E402
from nnfmu.vehicle import DriveSettings, generate_drive  # noqa: E402
from nnfmu.workflows.passivity import passivity_warnings  # noqa: E402
from nnfmu.workflows.roadtest import network_errors  # noqa: E402
from nnfmu.workflows.roadtest.stabilisers import bushing_stabilisers  # noqa: E402
from nnfmu.workflows.roadtest.systems import (  # noqa: E402
    build_component_fmus,
    build_truth_fmus,
    build_vehicle,
    bushing_elements,
    vehicle_components,
    write_system,
)
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference  # noqa: E402
from nnfmu.workflows.system import FmuCache  # noqa: E402

SYSTEM = "full-vehicle"
DAMPER = "damper-hysteresis"
H = 1e-3  # [s] the outer (plain master's) step
FINE = 1e-4  # [s] the container's inner step and the vehicle's sample period
QUICK_RECORDS = {"damper": 40.0, "bushing": 40.0}  # [s] rig records for the quick networks
QUICK_TRAINING = {"restarts": 1, "max_epochs": 15}
DAMPERS = tuple(f"damper_{c}_force" for c in ("fl", "fr", "rl", "rr"))
BODY = tuple(f"body_acceleration_{c}" for c in ("fl", "fr", "rl", "rr", "heave", "roll", "pitch"))
CHANNELS = DAMPERS + BODY
TARGET_RATIO = 1.5  # issue 33: the container within 1.5x of the networks' own error


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def cpu_seconds() -> float:
    """User + system CPU time [s] of this process and its finished children."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def plain_loop(
    fmu: Path, drive: Measurement, duration: float, slopes: bool = False
) -> tuple[dict[str, np.ndarray], float]:
    """The system FMU stepped at H by the tests' hand-written fmpy loop (`plain_run`, no nnfmu code inside):
    instantiate, drive at t_0 set in Initialization Mode, then per step the drive at t_n, doStep(t_n, H) and every
    output read; no input derivatives unless `slopes` (a diagnostic, not a plain master: the drive's slope over each
    step, (u_{n+1} - u_n) / H, set with fmi2SetRealInputDerivatives). Returns the outputs at t_0 .. t_N and the
    loop's wall time [s] (the FMU's unpacking included)."""
    inputs, outputs = port_names(fmu, "input"), port_names(fmu, "output")
    u = DriveInputs(drive, inputs).table(np.arange(round(duration / H) + 1) * H)  # prepared before the loop
    started = time.perf_counter()
    table = plain_run(fmu, dict(zip(inputs, u.T)), H, outputs, at_start=True, slopes=slopes, instance="car")
    wall = time.perf_counter() - started
    return {name: table[:, i] for i, name in enumerate(outputs)}, wall


def fmpy_simulate(fmu: Path, drive: Measurement, duration: float) -> dict[str, np.ndarray]:
    """The system FMU run by fmpy's own `simulate_fmu` at H (the drive as fmpy's input table, at its samples)."""
    inputs = port_names(fmu, "input")
    times = np.arange(round(duration / H) + 1) * H
    u = DriveInputs(drive, inputs).table(times)
    signals = np.zeros(len(times), dtype=[("time", float)] + [(n, float) for n in inputs])
    signals["time"] = times
    for i, name in enumerate(inputs):
        signals[name] = u[:, i]
    result = simulate_fmu(
        str(fmu),
        stop_time=duration,
        step_size=H,
        output_interval=H,
        input=signals,
        output=list(CHANNELS),
    )
    return {name: np.asarray(result[name], dtype=float) for name in CHANNELS}


def as_measurement(values: dict[str, np.ndarray], units: dict[str, str], source: str) -> Measurement:
    """`values` (sampled at H from t = 0) as a Measurement of CHANNELS."""
    n = len(values[CHANNELS[0]])
    return Measurement(np.arange(n) * H, {c: values[c] for c in CHANNELS}, {c: units[c] for c in CHANNELS}, source)


def nrmse(result: Measurement, reference: Measurement, validation: ValidationSettings) -> dict[str, float]:
    """Per channel the NRMSE [1] of `result` against `reference` (the road test's metric, `nnfmu.validate`)."""
    return {c.name: float(c.metrics.nrmse) for c in compare(result, reference, list(CHANNELS), validation)}


def system_fmu(ssd: Path, out: Path, inner: float, extrapolate: bool = True) -> Path:
    """`nnfmu system build SSD --out OUT --step 1e-3 --inner-step INNER` (`extrapolate` False: `--hold-drive`),
    port derivatives off."""
    started = time.perf_counter()
    with open_system(ssd) as system:
        build_system_fmu(system, out, H, inner, CosimSettings(port_derivatives=False), extrapolate_drive=extrapolate)
    log(f"built {out.name} in {time.perf_counter() - started:.1f} s")
    return out


def road_test_cosim(ssd: Path, drive: Measurement, duration: float) -> Measurement:
    """`ssd` co-simulated on nnfmu's master at 1 ms with its defaults, as the road test runs it."""
    with open_system(ssd) as system:
        result = cosimulate(system, drive, CosimSettings(step=H, stop_time=duration)).measurement
    return result


def ratio_table(errors: dict[str, float], own: dict[str, float]) -> dict[str, float]:
    return {c: errors[c] / own[c] for c in CHANNELS}


def rounded(values: dict[str, float], digits: int = 5) -> dict[str, float]:
    return {k: float(f"{v:.{digits}g}") for k, v in values.items()}


def main() -> None:
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 10.0
    loads = [os.getloadavg()[0]]
    cpu_start, wall_start = cpu_seconds(), time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nnfmu-bench-container-plain-") as scratch:
        work = Path(scratch)
        models_dir = Path(sys.argv[1]) if len(sys.argv) > 1 else work / "models"
        models = models_in(models_dir, QUICK_RECORDS, **QUICK_TRAINING)
        log(f"models ready at {time.perf_counter() - wall_start:.1f} s")
        fmus = build_component_fmus(models, work / "fmu", with_bushing=True)
        log(f"network FMUs built at {time.perf_counter() - wall_start:.1f} s")
        period = FmuCache().read(fmus.dampers[DAMPER]).component.sample_period
        truth = build_truth_fmus(work / "fmu", period if period is not None else H, True)
        graph = onnx.load(work / "fmu" / "lca-bushing.onnx")
        passivity = passivity_warnings("lca-bushing", graph)
        for line in passivity:
            log(f"warning: {line}")
        stabilisers = bushing_stabilisers(graph, bushing_elements(SYSTEM))
        log(f"truth FMUs, passivity and stabilisers at {time.perf_counter() - wall_start:.1f} s")
        drive = generate_drive(DriveSettings(road_class="C", speed=20.0, seed=0, duration=duration + H, fade_in=0.5))
        vehicles = {step: build_vehicle(SYSTEM, work / f"vehicle-{step:g}", step, stabilisers) for step in (FINE, H)}
        log(f"vehicle FMUs built at {time.perf_counter() - wall_start:.1f} s")
        parts = {"networks": (fmus.dampers[DAMPER], fmus.bushing), "truth": (truth.dampers["truth"], truth.bushing)}
        ssds = {
            (kind, step): write_system(SYSTEM, vehicles[step], damper, bushing, work / f"{kind}-{step:g}")
            for kind, (damper, bushing) in parts.items()
            for step in (FINE, H)
        }
        containers = {key: system_fmu(ssd, work / f"{key[0]}-{key[1]:g}.fmu", key[1]) for key, ssd in ssds.items()}
        # the coupling's split (truth laws): the drive held over each step; a 1 ms inner step on the 0.1 ms vehicle
        held = system_fmu(ssds["truth", FINE], work / "truth-held.fmu", FINE, extrapolate=False)
        coarse_on_fine = system_fmu(ssds["truth", FINE], work / "truth-1ms-on-fine-vehicle.fmu", H)
        # the networks' split: one kind of network at a time, the truth law in the other's places (h = 0.1 ms)
        mixed = {
            name: system_fmu(
                write_system(SYSTEM, vehicles[FINE], damper, bushing, work / name), work / f"{name}.fmu", FINE
            )
            for name, damper, bushing in (
                ("damper-networks-truth-bushings", fmus.dampers[DAMPER], truth.bushing),
                ("truth-dampers-bushing-networks", truth.dampers["truth"], fmus.bushing),
            )
        }
        prepared = time.perf_counter() - wall_start
        log(f"prepared in {prepared:.1f} s")

        started = time.perf_counter()
        reference = monolithic_reference(SYSTEM, drive, vehicle_components(SYSTEM), FINE).measurement
        reference_s = time.perf_counter() - started
        log(f"monolithic reference over {duration:g} s in {reference_s:.1f} s")
        units = dict(reference.units)
        validation = ValidationSettings()

        runs, walls = {}, {}
        for (kind, step), fmu in containers.items():
            values, walls[f"{kind}-{step:g}"] = plain_loop(fmu, drive, duration)
            runs[f"plain loop, {kind}, h = {step:g} s"] = as_measurement(values, units, f"{fmu.name} in a plain loop")
            log(f"plain loop {kind} h = {step:g} s: {walls[f'{kind}-{step:g}']:.2f} s")
        fine = containers["networks", FINE]
        runs["fmpy simulate_fmu, networks, h = 0.0001 s"] = as_measurement(
            fmpy_simulate(fine, drive, duration), units, "simulate_fmu"
        )
        for kind in parts:
            values, _ = plain_loop(containers[kind, FINE], drive, duration, slopes=True)
            runs[f"plain loop with input derivatives, {kind}, h = 0.0001 s"] = as_measurement(values, units, "slopes")
        values, _ = plain_loop(held, drive, duration)
        runs["plain loop, truth, drive held"] = as_measurement(values, units, "drive held")
        try:
            values, _ = plain_loop(coarse_on_fine, drive, duration)
            coarse_on_fine_error = rounded(nrmse(as_measurement(values, units, "1 ms"), reference, validation))
        except RuntimeError as error:  # the stabilised ports re-anchor at every vehicle sample, not every step
            coarse_on_fine_error = {"failed": str(error)}
            log(f"diverged: {error}")
        for name, fmu in mixed.items():
            values, _ = plain_loop(fmu, drive, duration)
            runs[f"plain loop, {name}, h = 0.0001 s"] = as_measurement(values, units, name)
        road = {kind: road_test_cosim(ssds[kind, H], drive, duration) for kind in parts}
        runs["nnfmu master at 1 ms (road test), networks"] = road["networks"]
        runs["nnfmu master at 1 ms (road test), truth"] = road["truth"]
        errors = {name: nrmse(run, reference, validation) for name, run in runs.items()}

        network = network_errors(
            SYSTEM, DAMPER, fmus, reference, road["networks"], road["truth"], list(CHANNELS), validation
        )
        own = {c: float(network[c].metrics.nrmse) for c in CHANNELS}
        container_own = nrmse(
            runs["plain loop, networks, h = 0.0001 s"], runs["plain loop, truth, h = 0.0001 s"], validation
        )
        plain_vs_fmpy = max(
            float(
                np.max(
                    np.abs(
                        runs["plain loop, networks, h = 0.0001 s"][c]
                        - runs["fmpy simulate_fmu, networks, h = 0.0001 s"][c]
                    )
                )
            )
            / float(np.max(np.abs(reference[c])))
            for c in CHANNELS
        )
    loads.append(os.getloadavg()[0])
    headline = errors["plain loop, networks, h = 0.0001 s"]
    ratios = ratio_table(headline, own)
    print(
        json.dumps(
            {
                "system": SYSTEM,
                "simulated_s": duration,
                "outer_step_s": H,
                "inner_step_s": FINE,
                "vehicle_sample_period_s": FINE,
                "network_sample_period_s": period,
                "channels": list(CHANNELS),
                "nrmse_container_plain_loop_h_0.1ms": rounded(headline),
                "nrmse_network_own": rounded(own),
                "ratio_to_network_own": rounded(ratios, 4),
                "largest_ratio": round(max(ratios.values()), 4),
                "target_ratio": TARGET_RATIO,
                "target_met": bool(max(ratios.values()) <= TARGET_RATIO),
                "nrmse_container_plain_loop_h_1ms": rounded(errors["plain loop, networks, h = 0.001 s"]),
                "ratio_h_1ms": rounded(ratio_table(errors["plain loop, networks, h = 0.001 s"], own), 4),
                "nrmse_coupling_truth_container_h_0.1ms": rounded(errors["plain loop, truth, h = 0.0001 s"]),
                "nrmse_coupling_truth_container_h_1ms": rounded(errors["plain loop, truth, h = 0.001 s"]),
                "coupling_split_truth_laws_as_fmus": {
                    "plain loop, h = 0.1 ms, drive extrapolated (the container's default)": rounded(
                        errors["plain loop, truth, h = 0.0001 s"]
                    ),
                    "plain loop, h = 0.1 ms, drive held (--hold-drive)": rounded(
                        errors["plain loop, truth, drive held"]
                    ),
                    "plain loop, h = 0.1 ms, drive slopes given (input derivatives)": rounded(
                        errors["plain loop with input derivatives, truth, h = 0.0001 s"]
                    ),
                    "plain loop, h = 1 ms, vehicle sampling at 0.1 ms": coarse_on_fine_error,
                    "plain loop, h = 1 ms, vehicle sampling at 1 ms": rounded(errors["plain loop, truth, h = 0.001 s"]),
                    "nnfmu master at 1 ms, drive interpolated (the road test's nrmse_coupling)": rounded(
                        errors["nnfmu master at 1 ms (road test), truth"]
                    ),
                },
                "nrmse_by_run": {name: rounded(e) for name, e in errors.items()},
                "split_by_network_h_0.1ms": {
                    name: rounded(errors[f"plain loop, {name}, h = 0.0001 s"]) for name in mixed
                },
                "checks": {
                    "nrmse_networks_vs_truth_container_plain_loop_h_0.1ms": rounded(container_own),
                    "plain_loop_vs_simulate_fmu_largest_difference_of_peak": plain_vs_fmpy,
                },
                "bushing_network_passivity": passivity or "passive in every sine test (docs/passivity.md)",
                "seconds": {
                    "prepare_wall": round(prepared, 1),
                    "reference_wall": round(reference_s, 1),
                    "plain_loop_wall": {k: round(v, 2) for k, v in walls.items()},
                    "total_wall": round(time.perf_counter() - wall_start, 1),
                    "total_cpu": round(cpu_seconds() - cpu_start, 1),
                },
                "setup": {
                    "drive": "ISO 8608 class C at 20 m/s, seed 0, 1 kHz, faded in over 0.5 s (the road test's)",
                    "reference": "monolithic full vehicle, truth laws, RK4 at 0.1 ms",
                    "damper_network": DAMPER,
                    "bushings": "4 merged LCA bushing network FMUs on stabilised ports, stabilisers fitted to them",
                    "models": str(models_dir) if len(sys.argv) > 1 else "quick-trained (bench)",
                    "metric": "NRMSE of nnfmu.validate (the road test's)",
                    "cpus": os.cpu_count(),
                    "load_average_1min_start_end": [round(v, 2) for v in loads],
                    "python": platform.python_version(),
                    "machine": platform.machine(),
                },
            },
            allow_nan=False,
        )
    )


if __name__ == "__main__":
    main()
