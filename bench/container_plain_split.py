"""Where the full vehicle's body accelerations go wrong in the system FMU at inner step 0.1 ms (one JSON line).

Usage: python bench/container_plain_split.py MODELS_DIR [DURATION_S] [FREQUENCY_HZ]
`bench/container_plain.py` found, with road-test-quality networks, the body accelerations 4.5-13x the networks' own
error at inner step 0.1 ms and 1.02-1.11x at 1 ms, from the bushing networks (docs/system-fmu.md, Accuracy). This
splits that further, on the same set-up (MODELS_DIR's networks, `bench/container_plain.py`'s builders, the road
test's drive over DURATION_S, default 5 s):
- `inner_step_sweep`: the vehicle sampling at h and the system FMU with inner step h, for h = 0.1, 0.2, 0.5 and 1 ms,
  in the plain fmpy loop at H = 1 ms: NRMSE of each body acceleration against the monolithic reference and the
  frequency [Hz] at which the error of body_acceleration_fl peaks above 50 Hz;
- `python_master_0.1ms`: nnfmu's own master (not the system FMU) at step 0.1 ms on the same system over the first
  min(3 s, DURATION_S), outputs every 0.1 ms: the same NRMSE and the error's peak frequency (no alias: 10 kHz output);
- `parameter_file_stabilisers`: the vehicle's stabilised ports on the parameter file's bushing elements instead of
  those fitted to the networks (inner step 0.1 ms);
- `truth_law_for_bushing_channels`: the bushing FMU with the truth law's axial force, radial force, both, or both
  torque channels in the networks' places (the other channels networks, merged as the road test merges them), inner
  step 0.1 ms;
- `bushing_sine_energy`: each channel of the merged bushing network driven alone by a sine at FREQUENCY_HZ (default:
  where the 0.1 ms run's error peaks; 5 % and 20 % of the reference's RMS deflection of bushing_fl_front, the mean
  not removed), stepped at 1 ms (its samples) and
  at 0.1 ms (evaluated between them): the sine of the loss angle (positive: the channel absorbs energy);
- `bushing_between_samples`: the bushing network replayed open loop at 0.1 ms on the reference's bushing_fl_front
  motion (linear between the reference's 1 ms samples): RMS and largest departure of its outputs from the line
  between its 1 ms samples, relative to the reference force's RMS.
Progress goes to stderr; stdout's last line is one JSON object.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import onnx
from container_plain import (  # bench/ is on the path when a bench script runs
    BODY,
    DAMPER,
    FINE,
    SYSTEM,
    H,
    as_measurement,
    cpu_seconds,
    log,
    plain_loop,
    rounded,
    system_fmu,
)
from plain_master import plain_run, port_names  # tests/cosim is on the path once container_plain is imported
from road_test import BUSHING_PRESET_BY_CHANNEL, models_in

from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import open_system
from nnfmu.data import Measurement
from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.export.merge import merge_step_graphs
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.validate import compare
from nnfmu.vehicle import DriveSettings, generate_drive, truth_laws
from nnfmu.workflows.roadtest.stabilisers import bushing_stabilisers
from nnfmu.workflows.roadtest.systems import (
    build_component_fmus,
    build_vehicle,
    bushing_elements,
    vehicle_components,
    write_system,
)
from nnfmu.workflows.roadtest.truth_graphs import bushing_truth_graph
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference

SWEEP = (1e-4, 2e-4, 5e-4, 1e-3)  # [s] inner steps (and vehicle sample periods)
ELEMENT = "bushing_fl_front"
AMPLITUDES = (0.05, 0.2)  # sine amplitudes as fractions of the reference's RMS deflection
MASTER_SPAN = 3.0  # [s] of nnfmu's Python master at 0.1 ms


def body_errors(result: Measurement, reference: Measurement) -> dict[str, float]:
    """NRMSE [1] of each body acceleration channel (the road test's metric)."""
    return rounded({c.name: float(c.metrics.nrmse) for c in compare(result, reference, list(BODY))}, 4)


def peak_frequency(time_: np.ndarray, values: np.ndarray, reference: Measurement, channel: str) -> float:
    """The frequency [Hz] above 50 Hz at which the error of `values` (at `time_`) against the reference peaks."""
    error = values - np.interp(time_, reference.time, reference[channel])
    step = float(time_[1] - time_[0])
    spectrum = np.abs(np.fft.rfft(error * np.hanning(len(error)))) ** 2
    frequencies = np.fft.rfftfreq(len(error), step)
    return round(float(frequencies[np.argmax(np.where(frequencies > 50.0, spectrum, 0.0))]), 1)


def stepped(fmu: Path, inputs: dict[str, np.ndarray], step: float, outputs: list[str]) -> np.ndarray:
    """`fmu` stepped at `step` [s] from t = 0 with `inputs` (one value per step end, 0 for an input not given) by the
    tests' plain fmpy loop (`plain_run`); `outputs` at every step end."""
    n = len(next(iter(inputs.values())))
    given = {name: inputs.get(name, np.zeros(n)) for name in port_names(fmu, "input")}
    return plain_run(fmu, given, step, outputs, instance="bushing")


def loss_sine(fmu: Path, channel, amplitude: float, frequency: float, step: float) -> float:
    """Sine of the loss angle of `channel` driven alone by x = A sin(w t), v = dx/dt at `step` [s]: the energy
    absorbed per cycle over the last 0.2 s of 0.5 s, over pi A |F1|."""
    w = 2 * np.pi * frequency
    t = np.arange(round(0.5 / step) + 1) * step
    x, v = amplitude * np.sin(w * t), amplitude * w * np.cos(w * t)
    force = stepped(fmu, {channel.position: x, channel.rate: v}, step, [channel.force])[:, 0]
    cycles = max(1, round(0.2 * frequency))
    m = round(cycles / frequency / step)
    energy = float(np.sum(force[-m:] * v[-m:]) * step / cycles)
    first = 2 * abs(np.mean(force[-m:] * np.exp(-1j * w * t[-m:])))
    return round(energy / (np.pi * amplitude * first), 3)


def channel_swap(models: dict[str, Path], chosen: tuple[str, ...], folder: Path) -> Path:
    """The bushing FMU with the truth law's channels `chosen` (keys of BUSHING_CHANNELS) and the networks' others,
    merged into one step graph as the road test merges the networks (host binary only)."""
    folder.mkdir(parents=True, exist_ok=True)
    laws = truth_laws([f"bushing_{BUSHING_CHANNELS[key].force}" for key in chosen])
    truth = bushing_truth_graph({key: laws[f"bushing_{BUSHING_CHANNELS[key].force}"].truth for key in chosen}, H)
    networks = [onnx.load(models[preset]) for key, preset in BUSHING_PRESET_BY_CHANNEL.items() if key not in chosen]
    onnx.save(
        merge_step_graphs([truth, *networks], "lca_bushing", f"truth law for {', '.join(chosen)}"), folder / "b.onnx"
    )
    return build_fmu(folder / "b.onnx", BuildOptions(out=folder / "lca-bushing.fmu", platforms=("host",)))


def main() -> None:
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 5.0
    loads = [os.getloadavg()[0]]
    cpu_start, wall_start = cpu_seconds(), time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nnfmu-bench-container-split-") as scratch:
        work = Path(scratch)
        models = models_in(Path(sys.argv[1]))
        fmus = build_component_fmus(models, work / "fmu", with_bushing=True)
        graph = onnx.load(work / "fmu" / "lca-bushing.onnx")
        stabilisers = bushing_stabilisers(graph, bushing_elements(SYSTEM))
        drive = generate_drive(DriveSettings(road_class="C", speed=20.0, seed=0, duration=duration + H, fade_in=0.5))
        reference = monolithic_reference(SYSTEM, drive, vehicle_components(SYSTEM), FINE).measurement
        units = dict(reference.units)
        log(f"prepared at {time.perf_counter() - wall_start:.1f} s")

        sweep, ssd_fine, vehicle_fine = {}, None, None
        for h in SWEEP:
            vehicle = build_vehicle(SYSTEM, work / f"vehicle-{h:g}", h, stabilisers)
            ssd = write_system(SYSTEM, vehicle, fmus.dampers[DAMPER], fmus.bushing, work / f"system-{h:g}")
            ssd_fine = ssd if h == FINE else ssd_fine
            vehicle_fine = vehicle if h == FINE else vehicle_fine
            values, _ = plain_loop(system_fmu(ssd, work / f"system-{h:g}.fmu", h), drive, duration)
            result = as_measurement(values, units, f"inner step {h:g} s")
            sweep[f"{h * 1e3:g} ms"] = {
                "nrmse": body_errors(result, reference),
                "error_peak_hz": peak_frequency(result.time, result["body_acceleration_fl"], reference, BODY[0]),
            }
            log(f"inner step {h:g} s: {json.dumps(sweep[f'{h * 1e3:g} ms'])}")

        span = min(MASTER_SPAN, duration)
        with open_system(ssd_fine) as system:
            fine = cosimulate(system, drive, CosimSettings(step=FINE, stop_time=span, port_derivatives=False))
        fine_result = fine.measurement
        every = round(H / FINE)
        sampled = Measurement(
            fine_result.time[::every],
            {c: fine_result[c][::every] for c in BODY},
            {c: fine_result.units[c] for c in BODY},
            "nnfmu master at 0.1 ms",
        )
        master = {
            "simulated_s": span,
            "nrmse": body_errors(sampled, reference),
            "error_peak_hz": peak_frequency(fine_result.time, fine_result[BODY[0]], reference, BODY[0]),
        }
        log(f"nnfmu master at 0.1 ms: {json.dumps(master)}")

        plain_vehicle = build_vehicle(SYSTEM, work / "vehicle-parameter-file", FINE, None)
        ssd = write_system(SYSTEM, plain_vehicle, fmus.dampers[DAMPER], fmus.bushing, work / "parameter-file")
        values, _ = plain_loop(system_fmu(ssd, work / "parameter-file.fmu", FINE), drive, duration)
        parameter_file = body_errors(as_measurement(values, units, "parameter-file stabilisers"), reference)

        swaps = {}
        for chosen in (("axial",), ("radial",), ("axial", "radial"), ("axial_rotation", "conical_rotation")):
            fmu = channel_swap(models, chosen, work / f"swap-{'+'.join(chosen)}")
            ssd = write_system(SYSTEM, vehicle_fine, fmus.dampers[DAMPER], fmu, work / f"swap-{'+'.join(chosen)}")
            values, _ = plain_loop(system_fmu(ssd, work / f"swap-{'+'.join(chosen)}.fmu", FINE), drive, duration)
            swaps[" + ".join(chosen)] = body_errors(as_measurement(values, units, "swap"), reference)
            log(f"truth law for {chosen}: {json.dumps(swaps[' + '.join(chosen)])}")

        frequency = float(sys.argv[3]) if len(sys.argv) > 3 else sweep["0.1 ms"]["error_peak_hz"]
        energy = {}
        for key, channel in BUSHING_CHANNELS.items():
            rms = float(np.sqrt(np.mean(reference[f"{ELEMENT}_{channel.position}"] ** 2)))
            for fraction in AMPLITUDES:
                energy[f"{key} at {fraction:g} x RMS"] = {
                    f"stepped at {step * 1e3:g} ms": loss_sine(fmus.bushing, channel, fraction * rms, frequency, step)
                    for step in (H, FINE)
                }

        times = reference.time[0] + np.arange((len(reference.time) - 1) * every + 1) * FINE
        motion = {
            name: np.interp(times, reference.time, reference[f"{ELEMENT}_{name}"])
            for channel in BUSHING_CHANNELS.values()
            for name in (channel.position, channel.rate)
        }
        forces = [channel.force for channel in BUSHING_CHANNELS.values()]
        replayed = stepped(fmus.bushing, motion, FINE, forces)
        between = {}
        for i, force in enumerate(forces):
            line = np.interp(times, times[::every], replayed[::every, i])
            scale = float(np.sqrt(np.mean(reference[f"{ELEMENT}_{force}"] ** 2)))
            departure = replayed[:, i] - line
            between[force] = {
                "rms_of_reference_rms": float(f"{np.sqrt(np.mean(departure**2)) / scale:.3g}"),
                "largest_of_reference_rms": float(f"{np.max(np.abs(departure)) / scale:.3g}"),
            }
    loads.append(os.getloadavg()[0])
    print(
        json.dumps(
            {
                "system": SYSTEM,
                "simulated_s": duration,
                "outer_step_s": H,
                "inner_step_sweep": sweep,
                "python_master_0.1ms": master,
                "parameter_file_stabilisers_0.1ms": parameter_file,
                "truth_law_for_bushing_channels_0.1ms": swaps,
                "oscillation_hz": frequency,
                "bushing_sine_energy_loss_angle_sine": energy,
                "bushing_between_samples": between,
                "models": sys.argv[1],
                "seconds": {
                    "total_wall": round(time.perf_counter() - wall_start, 1),
                    "total_cpu": round(cpu_seconds() - cpu_start, 1),
                },
                "load_average_1min_start_end": [round(v, 2) for v in loads],
            },
            allow_nan=False,
        )
    )


if __name__ == "__main__":
    main()
