"""Example: close the loop on the measured BRFD friction damper (backlash), starting from a velocity-only network.

Usage: python examples/brfd_loop.py FILE.json.gz [FILE ...] --out DIR [--json RESULT.json] [--max-effects 3]
       [--hidden 5] [--restarts 2] [--segments-per-file 2] [--effects NAME,NAME,...]

The runs given are joined in order into one record (`load_brfd_series`) and cut by the loop into fit, diagnosis and
test parts, `--segments-per-file` segments per run (so runs of equal length each get their own parts). A velocity-only
network (the damper-hysteresis preset: velocity, its differences over 2 and 8 samples, a friction sign; no
displacement) is trained as `nnfmu train` would, small and quick, on the fit part only; then `run_loop` replays its
FMU, diagnoses the residual on the diagnosis part, adds the effects it finds, retrains, rebuilds and reports under
DIR (report.html, report.json). Every error is on the test part, never fitted on. Prints, and writes to --json, the
before/after summary with the data's attribution: CC BY-SA 4.0, Coble, Huggins, Cao, Ricles, Downey,
"Dataset-Friction-Damper-with-Backlash", 2022.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from nnfmu.atomic import write_text_atomic
from nnfmu.data.importers import BRFD_LICENCE, load_brfd_series
from nnfmu.diagnosis import EFFECTS, DiagnosisSettings
from nnfmu.export import export_onnx
from nnfmu.models import train_model
from nnfmu.workflows.loop import LoopReport, run_loop
from nnfmu.workflows.loop.blocks import part_measurement, plan_blocks
from nnfmu.workflows.loop.settings import LoopSettings
from nnfmu.workflows.train import TrainRequest, resolve

PRESET = "damper-hysteresis"


def _table(report: LoopReport) -> str:
    """The held-out before/after errors as a markdown table."""
    rows = ["| model | test NRMSE | test R² | peak error | pseudo-damage ratio |", "|---|---|---|---|---|"]
    named = [("velocity-only", report.error_before)]
    named += [(f"+ {it.effect}", it.error_after) for it in report.iterations if it.accepted]
    for name, e in named:
        rows.append(
            f"| {name} | {e['nrmse']:.3f} | {e['r2']:.3f} | {e['peak_error']:+.3f} | {e['pseudo_damage_ratio']:.3f} |"
        )
    return "\n".join(rows)


def _summary(
    files: list[str], m: Any, report: LoopReport, settings: LoopSettings, features: list[str], seconds: dict[str, float]
) -> dict[str, Any]:
    """What the README table needs: the data, the starting model, each effect added and the test errors."""
    return {
        "data": {
            "files": [Path(f).name for f in files],
            "samples": len(m),
            "duration_s": float(m.time[-1]),
            "sample_rate_hz": 1 / m.sample_period,
            "runs": m.notes["runs"],
            "licence": BRFD_LICENCE,
        },
        "start_model": {"preset": PRESET, "features": features},
        "loop": {
            "max_effects": settings.max_effects,
            "segments": settings.segments,
            "effects_ranked": list(settings.diagnosis.effects or EFFECTS),
            "blocks": report.blocks,
        },
        "effects_added": report.effects_added,
        "iterations": [
            {
                "effect": it.effect,
                "features_added": list(it.features_added),
                "accepted": it.accepted,
                "explained_variance": it.explained_variance,
                "p_value": it.p_value,
                "reason": it.reason,
                "test_error_before": it.error_before,
                "test_error_after": it.error_after,
                "extra_hidden_units": it.extra_hidden,
                "retrained_from": f"{it.start} start",
            }
            for it in report.iterations
        ],
        "test_error_before": report.error_before,
        "test_error_after": report.error_after,
        "first_diagnosis": report.diagnoses[0].summary,
        "stop_reading": reading.to_dict() if (reading := report.diagnoses[0].stop_reading) else None,
        "final_diagnosis": report.diagnoses[-1].summary,
        "consistent_with_noise": report.consistent_with_noise,
        "notes": report.notes,
        "seconds": seconds,
        "table": _table(report),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", help="BRFD runs (.json.gz), joined in this order")
    parser.add_argument("--out", required=True, type=Path, help="folder for the models and the loop's report")
    parser.add_argument("--json", type=Path, help="where to write the before/after summary (JSON)")
    parser.add_argument("--max-effects", type=int, default=3)
    parser.add_argument("--hidden", type=int, default=5, help="hidden units of the velocity-only network")
    parser.add_argument("--restarts", type=int, default=2, help="training restarts of the velocity-only network")
    parser.add_argument("--segments-per-file", type=int, default=2)
    parser.add_argument(
        "--effects",
        help="comma-separated effect families the diagnosis may rank (default: all; "
        "e.g. leave out gas_force, the damper has no gas spring)",
    )
    args = parser.parse_args()

    started = time.perf_counter()
    m = load_brfd_series(args.files)
    effects = tuple(name.strip() for name in args.effects.split(",")) if args.effects else None
    settings = LoopSettings(
        max_effects=args.max_effects,
        segments=args.segments_per_file * len(args.files),
        diagnosis=DiagnosisSettings(effects=effects),
    )
    # Train only on the loop's fit part (its training and validation rows), so the diagnosis and test parts stay
    # unseen by the first model too.
    blocks = plan_blocks(len(m), settings, m.source)
    fit = part_measurement(m, np.concatenate([blocks.rows("train"), blocks.rows("validation")]), "fit")
    preset, architecture, training = resolve(TrainRequest(preset=PRESET, hidden=(args.hidden,), restarts=args.restarts))
    model = train_model(fit, preset.spec, architecture, training).model
    args.out.mkdir(parents=True, exist_ok=True)
    onnx_path = args.out / "velocity_only.onnx"
    export_onnx(
        model,
        onnx_path,
        name="brfd_force",
        verify_on={c: fit[c] for c in model.spec.channels},
        description=f"velocity-only force model of the BRFD friction damper ({', '.join(args.files)})",
    )
    trained = time.perf_counter()
    report = run_loop(m, onnx_path, "force", args.out / "loop", settings)
    done = time.perf_counter()
    seconds = {"train": trained - started, "loop": done - trained, "total": done - started}
    summary = _summary(args.files, m, report, settings, model.spec.feature_names, seconds)
    text = json.dumps(summary, indent=1)
    if args.json:
        write_text_atomic(args.json, text + "\n")
    print(text)
    print(summary["table"])


if __name__ == "__main__":
    main()
