"""Bench: `run_loop` on damper-rig records with undeclared effects, one at a time and two at once, starting from a
velocity-history network trained the way `nnfmu train` does (hidden size by validation, several restarts).

Prints one JSON line per case: the effects added, the test-part NRMSE against the measurement before and after,
and the NRMSE against the noise-free truth of a fresh record (another seed) before and after, with their ratio (the
issue's target: at most 0.5). Usage: python bench/loop_effects.py [--duration 30] [--case gas_force ...]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
import onnx

from nnfmu.component import Component
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.export import export_onnx, run_step_graph
from nnfmu.loop.blocks import part_measurement, plan_blocks
from nnfmu.loop.loop_settings import LoopSettings
from nnfmu.loop.run import run_loop
from nnfmu.models import TrainSettings, get_preset, train_model

BASE = ("hysteresis", "inertia")
CASES = {
    "gas_force": (*BASE, "gas_force"),
    "seal_friction": (*BASE, "seal_friction"),
    "temperature": (*BASE, "temperature"),
    "gas_force+seal_friction": (*BASE, "seal_friction", "gas_force"),
    "gas_force+temperature": (*BASE, "gas_force", "temperature"),
    "none": BASE,
}


def truth_nrmse(path: Path, effects: tuple[str, ...]) -> float:
    """NRMSE of the step graph at `path` against the noise-free force of a fresh 20 s record (seed 7)."""
    m = simulate_rig("damper", RigOptions(duration=20.0, seed=7, effects=effects, excitation="random",
                                          noise=0.0)).measurement
    component = Component.from_onnx(onnx.load(str(path)))
    predicted = run_step_graph(path, {p.name: m[p.name] for p in component.inputs})["force"]
    return float(np.sqrt(np.mean((predicted - m["force"]) ** 2)) / np.sqrt(np.mean(m["force"] ** 2)))


def run_case(name: str, duration: float, folder: Path) -> dict:
    effects = CASES[name]
    m = simulate_rig("damper", RigOptions(duration=duration, seed=1, effects=effects,
                                          excitation="random")).measurement
    settings = LoopSettings()
    preset = get_preset("damper-hysteresis")
    started = time.perf_counter()
    fit = part_measurement(m, plan_blocks(len(m), settings, m.source).rows("train"), "fit")
    first = train_model(fit, preset.spec, preset.architecture, TrainSettings(restarts=2)).model
    onnx_path = folder / f"{name}.onnx"
    export_onnx(first, onnx_path)
    report = run_loop(m, onnx_path, "force", folder / name, settings)
    before, after = truth_nrmse(onnx_path, effects), truth_nrmse(report.onnx, effects)
    return {
        "case": name, "truth_effects": list(effects), "effects_added": report.effects_added,
        "test_nrmse_before": report.error_before["nrmse"], "test_nrmse_after": report.error_after["nrmse"],
        "truth_nrmse_before": before, "truth_nrmse_after": after, "truth_ratio": after / before,
        "consistent_with_noise": report.consistent_with_noise, "seconds": time.perf_counter() - started,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--case", action="append", choices=sorted(CASES))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.case or list(CASES):
            print(json.dumps(run_case(name, args.duration, Path(tmp))), flush=True)


if __name__ == "__main__":
    main()
