"""Benchmark of `nnfmu characterise` on trained networks against the rigs' truth physics; the last stdout line is JSON.

The demo's damper-hysteresis network and its bushing networks (one per channel: axial force, radial force, axial
torque, conical torque; `--channels` picks) are trained on the simulated lab records (damper dyno: 70 s, sine series
then random stroke, default effects hysteresis, seal friction, inertia, the dyno's 2 kg moving mass taken out as
`nnfmu demo` does; bushing rig: 80 s, the dynamic-stiffness series then random drive, viscoelastic and friction;
seed 0, realistic noise), `--quick` as
`nnfmu demo --quick` trains them (one start, the thesis's hidden size, 8 Levenberg-Marquardt epochs). Each network is
then characterised through its FMU at the standard tests, and the same tests are run on the truth law directly (10
integration steps per sample; the damper's without its inertia, which the network was trained without). Per test
point: the deviation from the truth, beside the network's own error (test-split NRMSE and RMS error of the output).
The damper is also characterised beside its lab record's sine series, each bushing beside its lab record's
stiffness series (`--measured`; a bushing point says whether that series held it). Each network's own error is its
FMU's RMS force error on a held-out noise-free random record (30 s, seed 1; the damper's with the fixture's m·a taken
out, as in training); a damper test speed is within it when its rebound and jounce force deviations each are at most
that, a dynamic-stiffness point when the RMS of its first-harmonic force deviation |K*model − K*truth|·x/√2 is at most
that (and, as a share of the force, when |K*model − K*truth| / |K*truth| is at most the network's held-out NRMSE: the
random record's forces are mostly smaller than a full-amplitude sine's); each point says whether it lies inside the
network's training envelope (its inputs' range, and the frequency band its record excited), and the quasi-static
loop is compared with the truth's along the same motion (force at the largest deflections, loop area, RMS
difference). `--work DIR` keeps the trained network there and reuses it on the next run (the JSON's `network` says
how it was trained).

Usage: python bench/characterise.py [--quick] [--only damper|bushing] [--channels KEY ...] [--work DIR] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from road_test import BUSHING_PRESET_BY_CHANNEL  # bench/ is on the path when a bench script runs

from nnfmu.data import load_measurement
from nnfmu.data.inertia import compensate_inertia
from nnfmu.data.rigs import (
    BUSHING_CHANNELS,
    DEFAULT_EFFECTS,
    BushingChannelTruth,
    BushingParams,
    BushingRig,
    DamperParams,
    DamperTruth,
    RigOptions,
    write_rig,
)
from nnfmu.models import get_preset
from nnfmu.workflows.characterise import CharacteriseSettings, characterise
from nnfmu.workflows.characterise.analysis import StiffnessPoint
from nnfmu.workflows.characterise.bushing import channel_plan, read_channel
from nnfmu.workflows.characterise.damper import damper_tests, read_damper
from nnfmu.workflows.characterise.kind import BushingChannelPorts
from nnfmu.workflows.characterise.tables import harmonic_force_deviation
from nnfmu.workflows.characterise.truth import bushing_truth_runs, damper_truth_runs
from nnfmu.workflows.train import TrainRequest, train_from_file

T = 1e-3
QUICK_EPOCHS = 8  # nnfmu demo --quick


def _request(preset: str, quick: bool, moving_mass: float) -> TrainRequest:
    if quick:
        hidden = get_preset(preset).architecture.hidden[:1]
        return TrainRequest(preset, restarts=1, max_epochs=QUICK_EPOCHS, hidden=hidden, moving_mass=moving_mass)
    return TrainRequest(preset, moving_mass=moving_mass)


def _train(kind: str, preset: str, quick: bool, folder: Path, moving_mass: float = 0.0) -> tuple[Path, Path, dict]:
    """The lab record of `kind`, the trained network's ONNX and its own error."""
    data, _truth = write_rig(kind, folder / f"{kind}_lab.csv", RigOptions(seed=0))
    started = time.perf_counter()
    outcome = train_from_file(data, _request(preset, quick, moving_mass), folder / f"{preset}.onnx")
    model = outcome.model
    output = model.spec.output
    measured = load_measurement(data)
    if moving_mass:
        measured = compensate_inertia(measured, moving_mass, output)
    prediction = model.predict({c: measured[c] for c in model.spec.channels})
    target = np.asarray(measured[output])
    error = {
        "preset": preset,
        "train_seconds": round(time.perf_counter() - started, 1),
        "test_split_nrmse": model.metrics["test"]["nrmse"],
        "lab_record_rms_error": float(np.sqrt(np.mean((prediction - target) ** 2))),  # noisy record, whole
        "output_unit": model.units[output],
        "training_band_Hz": model.band,  # per input: 99 % of its power below (a test above it is outside)
    }
    return data, outcome.path, error


def bench_damper(quick: bool, folder: Path) -> dict:
    mass = DamperParams().moving_mass
    data, onnx_path, own = _train("damper", "damper-hysteresis", quick, folder, mass)
    settings = CharacteriseSettings()
    characterise(onnx_path, folder / "damper_report", settings=settings, log=lambda _: None)
    rows = _csv(folder / "damper_report" / "characteristic.csv")
    effects = tuple(e for e in DEFAULT_EFFECTS["damper"] if e != "inertia")
    tests = damper_tests(settings.damper, [None])
    truth = read_damper(damper_truth_runs(DamperTruth(DamperParams(), effects), tests, T))
    own = own | _own_error(onnx_path, "damper", mass)
    points = []
    for row, p in zip(rows, truth.points, strict=True):
        rebound = row["rebound_force [N]"] - p.rebound_force
        jounce = row["jounce_force [N]"] - p.jounce_force
        points.append(
            {
                "peak_velocity_m/s": round(p.peak_velocity, 4),
                "rebound_N": {"model": row["rebound_force [N]"], "truth": p.rebound_force},
                "jounce_N": {"model": row["jounce_force [N]"], "truth": p.jounce_force},
                "rebound_deviation_N": rebound,
                "jounce_deviation_N": jounce,
                "rebound_deviation_%": 100 * rebound / abs(p.rebound_force),
                "jounce_deviation_%": 100 * jounce / abs(p.jounce_force),
                "rebound_over_own_error": abs(rebound) / own["heldout_rms_error"],
                "jounce_over_own_error": abs(jounce) / own["heldout_rms_error"],
                "within_own_error": max(abs(rebound), abs(jounce)) <= own["heldout_rms_error"],
            }
        )
    (gas,) = _csv(folder / "damper_report" / "gas_friction.csv")
    characterise(onnx_path, folder / "damper_measured", data, settings, log=lambda _: None)
    measured = [
        {
            "peak_velocity_m/s": round(r["measured_peak_velocity [m/s]"], 4),
            "rebound_deviation_N": r["rebound_deviation [N]"],
            "jounce_deviation_N": r["jounce_deviation [N]"],
        }
        for r in _csv(folder / "damper_measured" / "characteristic.csv")
    ]
    return {
        "network": own,
        "own_error_rule": "a test speed is within the network's own error when its rebound and jounce force each "
        "deviate from the truth's by at most the network's RMS force error on the held-out noise-free record",
        "within_own_error": [sum(p["within_own_error"] for p in points), len(points)],
        "stroke_amplitude_m": settings.damper.stroke,
        "truth_effects": list(effects),
        "points_vs_truth": points,
        "gas_force_N": {"model": gas["gas_force [N]"], "truth": truth.gas_friction[None].gas_force},
        "friction_N": {"model": gas["friction [N]"], "truth": truth.gas_friction[None].friction},
        "points_vs_lab_sine_series": measured,
    }


def _own_error(onnx_path: Path, kind: str, moving_mass: float = 0.0, seconds: float = 30.0) -> dict:
    """The network's own error on a held-out noise-free random record of rig `kind` (seed 1, the rig's "random" drive
    inside the lab envelope), through its FMU as the characterisation runs it: the RMS of its force less the record's
    (a damper's with the fixture's `moving_mass` times acceleration taken out, as in training), beside the record
    force's RMS."""
    from nnfmu.cosim.replay import replay_fmu
    from nnfmu.workflows.characterise.model import model_under_test

    with tempfile.TemporaryDirectory(prefix="nnfmu_heldout_") as tmp:
        options = RigOptions(seed=1, duration=seconds, noise=0.0, excitation="random")
        data, _truth = write_rig(kind, Path(tmp) / "heldout.csv", options)
        measured = load_measurement(data)
    with model_under_test(onnx_path) as model:
        output = "force" if kind == "damper" else model.kind.channels[0].force
        prediction = np.asarray(replay_fmu(model.fmu, measured)[output])
    if moving_mass:
        measured = compensate_inertia(measured, moving_mass, output)
    target = np.asarray(measured[output])
    rms = float(np.sqrt(np.mean((prediction - target) ** 2)))
    spread = float(np.sqrt(np.mean((target - target.mean()) ** 2)))
    taken_out = f", {moving_mass:g} kg m·a taken out" if moving_mass else ""
    return {
        "heldout_clean_record": f"{kind} rig, random drive, {seconds:g} s, seed 1, no sensor noise{taken_out}",
        "heldout_rms_error": rms,
        "heldout_truth_rms": spread,
        "heldout_nrmse_%": 100 * rms / spread,
    }


def _loop_compare(onnx_path: Path, plan, truth: BushingChannelTruth, channel: BushingChannelPorts) -> dict:
    """The quasi-static loop of the model (through its FMU) against the truth's along the same motion: force at the
    largest deflection each way, the loop's area (energy per cycle) and the RMS force difference over the cycle."""
    from nnfmu.workflows.characterise.bushing import channel_inputs
    from nnfmu.workflows.characterise.model import model_under_test, run_test

    with model_under_test(onnx_path) as model:
        run = run_test(model, plan.loop, channel_inputs(model.kind, plan.channel), plan.channel.force)
    (true_run,) = bushing_truth_runs(truth, [plan.loop], T)
    t, x, _v, f = run.cycle()
    tt, _xt, _vt, ft = true_run.cycle()
    f_truth = np.interp(t, tt, ft)

    def area(force: np.ndarray) -> float:
        closed_x, closed_f = np.append(x, x[0]), np.append(force, force[0])
        return float(abs(np.sum(0.5 * (closed_f[1:] + closed_f[:-1]) * np.diff(closed_x))))

    top, bottom = int(np.argmax(x)), int(np.argmin(x))
    return {
        "frequency_Hz": plan.loop.frequency,
        f"amplitude_{channel.position_unit}": plan.loop.amplitude,
        f"force_at_max_deflection_{channel.force_unit}": {"model": float(f[top]), "truth": float(f_truth[top])},
        f"force_at_min_deflection_{channel.force_unit}": {"model": float(f[bottom]), "truth": float(f_truth[bottom])},
        "loop_area_J": {"model": area(f), "truth": area(f_truth)},
        f"rms_difference_{channel.force_unit}": float(np.sqrt(np.mean((f - f_truth) ** 2))),
    }


def bench_bushing(quick: bool, folder: Path, key: str) -> dict:
    """Bushing channel `key` (a `BUSHING_CHANNELS` key): its preset trained on the lab record, characterised through
    its FMU and compared with the channel's truth law point by point, beside the network's own error."""
    preset = BUSHING_PRESET_BY_CHANNEL[key]
    onnx_path = folder / f"{preset}.onnx"
    if onnx_path.is_file():  # a kept work folder: the network trained before (its error recorded beside it)
        own = json.loads((folder / f"{preset}.json").read_text(encoding="utf-8"))
    else:
        _data, onnx_path, own = _train("bushing", preset, quick, folder)
        (folder / f"{preset}.json").write_text(json.dumps(own), encoding="utf-8")
    rig = BushingRig()
    series = {(f, round(a * rig.vehicle_range[key], 12)) for f in rig.sine_frequencies for a in rig.sine_amplitudes}
    own = own | _own_error(onnx_path, "bushing")
    settings = CharacteriseSettings()
    characterise(onnx_path, folder / f"{preset}_report", settings=settings, log=lambda _: None)
    rows = _csv(folder / f"{preset}_report" / "dynamic_stiffness.csv")
    spec = BUSHING_CHANNELS[key]
    channel = BushingChannelPorts(key, spec.position, spec.rate, spec.force, spec.position_unit, spec.force_unit)
    plan = channel_plan(channel, settings.bushing)
    law = BushingChannelTruth(getattr(BushingParams(), key))
    truth = read_channel(key, bushing_truth_runs(law, plan.stiffness, T))
    position, force, stiffness = channel.position_unit, channel.force_unit, channel.stiffness_unit
    points = []
    for row, p in zip(rows, truth, strict=True):
        model_k = row[f"dynamic_stiffness [{stiffness}]"]
        model_point = StiffnessPoint(key, p.frequency, p.amplitude, model_k, row["loss_angle [deg]"])
        # the first-harmonic force the model gets wrong at this point, as an RMS beside the network's own RMS error
        harmonic_rms = harmonic_force_deviation(model_point, p)
        relative = float(100 * harmonic_rms / (p.dynamic_stiffness * p.amplitude / np.sqrt(2)))  # as a share of force
        points.append(
            {
                "frequency_Hz": p.frequency,
                f"amplitude_{position}": p.amplitude,
                f"dynamic_stiffness_{stiffness}": {"model": model_k, "truth": p.dynamic_stiffness},
                "loss_angle_deg": {"model": row["loss_angle [deg]"], "truth": p.loss_angle},
                "stiffness_deviation_%": 100 * (model_k - p.dynamic_stiffness) / p.dynamic_stiffness,
                "loss_angle_deviation_deg": row["loss_angle [deg]"] - p.loss_angle,
                f"first_harmonic_force_deviation_rms_{force}": harmonic_rms,
                "deviation_over_own_error": harmonic_rms / own["heldout_rms_error"],
                "within_own_error": harmonic_rms <= own["heldout_rms_error"],
                "relative_first_harmonic_deviation_%": relative,
                "within_own_relative_error": relative <= own["heldout_nrmse_%"],
                "training_envelope": row["training_envelope"],
                "in_lab_sine_series": (p.frequency, round(p.amplitude, 12)) in series,
            }
        )
    inside = [p for p in points if p["training_envelope"] == "inside"]
    characterise(onnx_path, folder / f"{preset}_measured", folder / "bushing_lab.csv", settings, log=lambda _: None)
    measured = [
        {
            "frequency_Hz": r["frequency [Hz]"],
            f"amplitude_{position}": r[f"amplitude [{position}]"],
            "stiffness_deviation_%": r["stiffness_deviation [%]"],
            "loss_angle_deviation_deg": r["loss_angle_deviation [deg]"],
        }
        for r in _csv(folder / f"{preset}_measured" / "dynamic_stiffness.csv")
        if r["channel"] == key
    ]
    return {
        "network": own,
        "channel": key,
        "own_error_rule": "a point is within the network's own error when the RMS of its first-harmonic force "
        "deviation |K*model - K*truth|·x/√2 is at most the network's RMS error on the held-out noise-free record",
        "inside_envelope_within_own_error": [sum(p["within_own_error"] for p in inside), len(inside)],
        "own_relative_error_rule": "a point is within the network's own relative error when |K*model - K*truth| / "
        "|K*truth| (the first-harmonic force deviation as a share of the force) is at most the network's NRMSE on "
        "the held-out noise-free record",
        "inside_envelope_within_own_relative_error": [sum(p["within_own_relative_error"] for p in inside), len(inside)],
        "points_vs_truth": points,
        "quasi_static_loop": _loop_compare(onnx_path, plan, law, channel),
        "points_vs_lab_sine_series": measured,
    }


def _csv(path: Path) -> list[dict]:
    """A report table with its numbers as floats."""
    import csv

    def value(text: str):
        try:
            return float(text)
        except ValueError:
            return text

    with path.open(encoding="utf-8") as stream:
        return [{k: value(v) for k, v in row.items()} for row in csv.DictReader(stream)]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="train as nnfmu demo --quick does")
    parser.add_argument("--out", type=Path, help="also write the JSON document here")
    parser.add_argument("--only", choices=("damper", "bushing"), help="characterise one component only")
    parser.add_argument("--work", type=Path, help="keep the work folder here; a network trained there is reused")
    parser.add_argument(
        "--channels",
        nargs="+",
        choices=tuple(BUSHING_PRESET_BY_CHANNEL),
        default=list(BUSHING_PRESET_BY_CHANNEL),
        help="bushing channels",
    )
    args = parser.parse_args(argv)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="nnfmu_characterise_") as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        damper = bench_damper(args.quick, work) if args.only != "bushing" else None
        bushing = (
            {key: bench_bushing(args.quick, work, key) for key in args.channels} if args.only != "damper" else None
        )
    document = {
        "benchmark": "nnfmu characterise on trained networks against the rigs' truth physics",
        "machine": {"python": platform.python_version(), "platform": platform.platform()},
        "training": "quick (nnfmu demo --quick)" if args.quick else "preset defaults (nnfmu demo)",
        "damper": damper,
        "bushing": bushing,
        "seconds": round(time.perf_counter() - started, 1),
    }
    text = json.dumps(document)
    if args.out:
        args.out.write_text(text + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    sys.exit(main())
