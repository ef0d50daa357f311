"""Bench: `run_loop` on damper-rig records with undeclared effects, one at a time and two at once, and on records
with nothing missing, starting from a network trained the way `nnfmu train` does (hidden size by validation, several
restarts) on a feature spec that lacks exactly the inputs of the effects under test.

Every damper-rig effect is covered: gas_force and temperature need inputs the velocity-history preset lacks
(displacement, temperature); seal_friction, hysteresis and inertia are functions of the velocity and its history, so
their cases start from the preset with the matching features taken out (no friction sign; no velocity history).

Prints one JSON object per case, then a summary line. Per case: the effects present and named, the NRMSE on the
loop's test blocks of the record against the measurement (the issue's target: after/before <= 0.5), against the
noise-free force of the same record (same noisy inputs), and against the noise-free force of a fresh record (another
seed, noise-free inputs).

Reference numbers show how far a case *can* fall. `missing_effect_nrmse`: the varying force of the missing effects
(the noise-free record minus the same record simulated without them, less its mean, which a network's bias holds) on
the test blocks, as a share of the rms measured force. `perfect_model`: the rig's own physics run on the recorded
(noisy) inputs, scored like the models; its ratio to the error before is the lowest ratio any model fed these inputs
could reach against this measurement. `removed`: the share of the reducible error the loop took out against the
measurement, (before² - after²) / (before² - perfect²); halving needs after² <= before² / 4.
Usage: python bench/loop_effects.py [--duration 40] [--noise 0.5] [--seed 1] [--case gas_force ...]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx

from nnfmu.component import Component
from nnfmu.data import Measurement
from nnfmu.data.rigs import DamperDyno, DamperTruth, RigOptions, simulate_rig
from nnfmu.export import export_onnx, run_step_graph
from nnfmu.models import TrainSettings, get_preset, train_model
from nnfmu.models.features import Difference, FeatureSpec, SmoothSign
from nnfmu.workflows.loop.blocks import part_measurement, plan_blocks
from nnfmu.workflows.loop.run import run_loop
from nnfmu.workflows.loop.settings import LoopSettings

# The rig's sensors at half their default noise: a 5 N rms load cell (0.05 % of its 10 kN range) and a 1 mm/s rms
# velocity transducer (0.05 % of 2 m/s), the quiet end of a damper dyno's 0.05-0.1 % of range.
NOISE = 0.5
TARGET_RATIO = 0.5  # the issue: the held-out NRMSE falls by at least half
FRESH_SEED = 7  # the fresh noise-free record scored against the truth (choose another --seed for the records)

HISTORY = get_preset("damper-hysteresis").spec  # velocity, its differences over 2 and 8 ms, the friction sign


def _without(spec: FeatureSpec, kind: type) -> FeatureSpec:
    return FeatureSpec(
        taps=spec.taps, output=spec.output, derived=tuple(d for d in spec.derived if not isinstance(d, kind))
    )


NO_SIGN = _without(HISTORY, SmoothSign)  # cannot form the seal's Coulomb step
STATIC = _without(HISTORY, Difference)  # no velocity history: no compliance lag, no acceleration


@dataclass(frozen=True)
class Case:
    """Rig effects switched on, the starting model's feature spec, and the effects it lacks."""

    effects: tuple[str, ...]
    spec: FeatureSpec
    missing: tuple[str, ...]
    noise_only: bool = False
    duration: float | None = None  # s; None: the --duration given


# The oil heats by ~6 K in 30 s of this drive and ~14 K in 60 s (heat capacity 1000 J/K, fade 0.4 %/K): after the
# gain the first network absorbs, the fade leaves 0.73 % NRMSE at 30 s, less than that network's own error, and
# 1.67 % at 60 s. A fade test runs long enough to heat the damper, so the temperature cases record 60 s.
HEATING = 60.0


FULL = ("hysteresis", "seal_friction", "inertia")
CASES = {
    "gas_force": Case((*FULL, "gas_force"), HISTORY, ("gas_force",)),
    "temperature": Case((*FULL, "temperature"), HISTORY, ("temperature",), duration=HEATING),
    "seal_friction": Case(FULL, NO_SIGN, ("seal_friction",)),
    "hysteresis": Case(("hysteresis", "seal_friction"), STATIC, ("hysteresis",)),
    "inertia": Case(("seal_friction", "inertia"), STATIC, ("inertia",)),
    "gas_force+temperature": Case(
        (*FULL, "gas_force", "temperature"), HISTORY, ("gas_force", "temperature"), duration=HEATING
    ),
    "gas_force+seal_friction": Case((*FULL, "gas_force"), NO_SIGN, ("gas_force", "seal_friction")),
    "temperature+inertia": Case(
        ("seal_friction", "inertia", "temperature"), STATIC, ("temperature", "inertia"), duration=HEATING
    ),
    "none": Case(FULL, HISTORY, ()),
    "noise_only": Case(FULL, HISTORY, (), noise_only=True),
}


def nrmse(predicted: np.ndarray, reference: np.ndarray) -> float:
    return float(np.sqrt(np.mean((predicted - reference) ** 2)) / np.sqrt(np.mean(reference**2)))


def predict(path: Path, m: Measurement) -> np.ndarray:
    component = Component.from_onnx(onnx.load(str(path)))
    return run_step_graph(path, {p.name: m[p.name] for p in component.inputs})["force"]


def record(effects: tuple[str, ...], duration: float, seed: int, noise: float) -> Measurement:
    return simulate_rig(
        "damper", RigOptions(duration=duration, seed=seed, effects=effects, excitation="random", noise=noise)
    ).measurement


def perfect_model(effects: tuple[str, ...], m: Measurement, clean: Measurement) -> np.ndarray:
    """The rig's truth law driven by the recorded displacement and velocity (at the rig's internal step, inputs
    interpolated; the inertia's acceleration is the true one): the best any model fed the recorded inputs can do."""
    substeps = max(1, round(m.sample_period / DamperDyno().internal_step))
    fine = np.arange((len(m) - 1) * substeps + 1) * (m.sample_period / substeps)
    x, v = (np.interp(fine, m.time - m.time[0], m[c]) for c in ("displacement", "velocity"))
    a = np.gradient(np.interp(fine, m.time - m.time[0], clean["velocity"]), fine)
    force, _ = DamperTruth(effects=effects).simulate(fine[1] - fine[0], x, v, a)
    return force[::substeps]


def missing_effect_nrmse(
    case: Case, clean: np.ndarray, duration: float, seed: int, measured: Measurement, rows: np.ndarray
) -> float:
    """Rms about its mean, on `rows`, of the missing effects' force (`clean`, the noise-free force of the case's
    record, minus the same record without them), as a share of the rms measured force there."""
    kept = tuple(e for e in case.effects if e not in case.missing)
    missing = (clean - record(kept, duration, seed, 0.0)["force"])[rows]
    return float(np.std(missing) / np.sqrt(np.mean(measured["force"][rows] ** 2)))


def run_case(name: str, duration: float, noise: float, seed: int, settings: LoopSettings, folder: Path) -> dict:
    case = CASES[name]
    duration = case.duration or duration
    m = record(case.effects, duration, seed, noise)
    clean_record = record(case.effects, duration, seed, 0.0)
    clean = clean_record["force"]
    # noise_only: the record's force is made from the model itself, so the rig's physics is no reference
    ideal = None if case.noise_only else perfect_model(case.effects, m, clean_record)
    started = time.perf_counter()
    blocks = plan_blocks(len(m), settings, m.source)
    fit = part_measurement(m, blocks.rows("train"), "fit")
    first = train_model(fit, case.spec, get_preset("damper-hysteresis").architecture, TrainSettings(restarts=2)).model
    first_fit = time.perf_counter() - started
    onnx_path = folder / f"{name}.onnx"
    export_onnx(first, onnx_path)
    if case.noise_only:  # the record's force is the model's own output plus the load cell's white noise
        clean = predict(onnx_path, m)
        noisy = clean + np.random.default_rng(3).normal(0.0, 10.0 * noise, len(clean))
        m = Measurement(m.time, {**m.channels, "force": noisy}, dict(m.units), "model + load-cell noise")
    report = run_loop(m, onnx_path, "force", folder / name, settings)
    seconds = time.perf_counter() - started
    looped = seconds - first_fit
    test = blocks.rows("test")
    fresh = record(case.effects, 20.0, FRESH_SEED, 0.0)
    errors = {}
    for label, path in (("before", onnx_path), ("after", report.onnx)):
        errors[label] = {
            "measured": nrmse(predict(path, m)[test], m["force"][test]),
            "noise_free": nrmse(predict(path, m)[test], clean[test]),
            "fresh_truth": nrmse(predict(path, fresh), fresh["force"]),
        }
    ratios = {k: errors["after"][k] / before if (before := errors["before"][k]) > 0 else None for k in errors["before"]}
    present = set(case.missing)
    missing = missing_effect_nrmse(case, clean, duration, seed, m, test) if present else None
    perfect = None if ideal is None else nrmse(ideal[test], m["force"][test])
    first_error, final_error = errors["before"]["measured"], errors["after"]["measured"]
    return {
        "case": name,
        "seed": seed,
        "duration_s": duration,
        "rig_effects": list(case.effects),
        "start_features": case.spec.feature_names,
        "missing": list(case.missing),
        "effects_added": report.effects_added,
        "named_correctly": set(report.effects_added) == present,
        "nrmse_before": errors["before"],
        "nrmse_after": errors["after"],
        "ratio": ratios,
        "halved": bool(ratios["measured"] <= TARGET_RATIO) if present else None,
        "missing_effect_nrmse": missing,
        "perfect_model": None if perfect is None else {"nrmse": perfect, "ratio": perfect / first_error},
        "removed": (
            (first_error**2 - final_error**2) / (first_error**2 - perfect**2)
            if present and perfect is not None
            else None
        ),
        "consistent_with_noise": report.consistent_with_noise,
        "summary": report.summary,
        "notes": report.notes,
        "first_fit_seconds": first_fit,
        "loop_seconds": looped,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=40.0)
    parser.add_argument("--noise", type=float, default=NOISE)
    parser.add_argument("--case", action="append", choices=sorted(CASES))
    parser.add_argument("--seed", type=int, default=1, help="seed of the rig records (motion and noise)")
    args = parser.parse_args()
    settings = LoopSettings()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.case or list(CASES):
            results.append(run_case(name, args.duration, args.noise, args.seed, settings, Path(tmp)))
            print(json.dumps(results[-1]), flush=True)
    effect_cases = [r for r in results if r["missing"]]
    print(
        json.dumps(
            {
                "summary": True,
                "duration_s": args.duration,
                "noise": args.noise,
                "seed": args.seed,
                "cases": len(results),
                "named_correctly": sum(r["named_correctly"] for r in results),
                "halved": sum(bool(r["halved"]) for r in effect_cases),
                "effect_cases": len(effect_cases),
                "worst_measured_ratio": max((r["ratio"]["measured"] for r in effect_cases), default=None),
                "least_removed": min((r["removed"] for r in effect_cases), default=None),
                "seconds": sum(r["first_fit_seconds"] + r["loop_seconds"] for r in results),
            }
        ),
        flush=True,
    )


if __name__ == "__main__":
    main()
