"""Example: close the loop on the measured BRFD friction damper, starting from a velocity-only network.

Usage: python brfd_loop.py FILE.json.gz [FILE ...] --out DIR [--max-effects 3] [--hidden 5]
For each file: import it (nnfmu.data.importers.load_brfd), train the damper-hysteresis preset (velocity on a delay
line, no displacement, no friction feature) on the fit part of the record, export it, then run `run_loop`, which
replays its FMU, diagnoses the residual on the diagnosis part, adds the effects it finds, retrains, rebuilds and
reports under DIR/<file stem>/. Prints one JSON line per file: effects added, test NRMSE before and after, verdict.
The loop needs at least 5000 samples (its diagnosis part is a fifth of the record and needs 1000); the two-second
slices in tests/data/brfd are too short, whole BRFD runs are long enough.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from nnfmu.data.importers import load_brfd
from nnfmu.export import export_onnx
from nnfmu.loop.blocks import part_measurement, plan_blocks
from nnfmu.loop.loop_settings import LoopSettings
from nnfmu.loop.run import run_loop
from nnfmu.models import Architecture, TrainSettings, get_preset, train_model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+")
    parser.add_argument("--out", required=True, help="folder for the models and the reports")
    parser.add_argument("--max-effects", type=int, default=3)
    parser.add_argument("--hidden", type=int, default=5)
    args = parser.parse_args()
    settings = LoopSettings(max_effects=args.max_effects)
    for path in args.files:
        m = load_brfd(path)
        stem = Path(path).name.split(".")[0]
        folder = Path(args.out) / stem
        # Train only on the loop's fit part, so its diagnosis and test parts stay unseen by the first model too.
        blocks = plan_blocks(len(m), settings, m.source)
        fit = part_measurement(m, blocks.rows("train"), "fit")
        spec = get_preset("damper-hysteresis").spec
        model = train_model(fit, spec, Architecture("mlp", (args.hidden,)), TrainSettings(restarts=2)).model
        onnx_path = folder.with_suffix(".velocity_only.onnx")
        export_onnx(model, onnx_path, name="brfd_force", description=f"velocity-only damper force model of {path}")
        report = run_loop(m, onnx_path, "force", folder, settings)
        print(json.dumps({
            "file": path, "effects_added": report.effects_added,
            "test_nrmse_before": report.error_before["nrmse"], "test_nrmse_after": report.error_after["nrmse"],
            "consistent_with_noise": report.consistent_with_noise, "summary": report.summary,
            "report": str(folder / "report.html"),
        }))


if __name__ == "__main__":
    main()
