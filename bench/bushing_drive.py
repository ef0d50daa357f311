"""Bushing networks trained on the lab record vs on a vehicle-derived rig record, judged along a held-out car motion.

Two monolithic references of the full vehicle (four LCA bushings with truth physics, stabilised ports): a source run
on drive seed --source-seed, whose bushing deflections the rig drive is derived from (`write_vehicle_rig`), and a
held-out run on --heldout-seed (default 0, the road test's drive). The four bushing presets are trained with their
defaults on the bushing rig's lab record (seed 0, "before") and on the vehicle-derived record ("after"); each set is
merged and built into the road test's bushing FMU, replayed open loop along the held-out motion of each front LCA
bushing and compared with the bushing truth physics along it (the road test's open-loop check), and every network
input is checked against its training envelope on all four bushings. Target: NRMSE <= 5 % per channel on
bushing_fl_front. Prints one JSON document (last line).

Usage: python bench/bushing_drive.py [--out DIR] [--duration S] [--source-seed N] [--heldout-seed N]
       [--rig-duration S] [--margin M] [--elements NAME ...] [--lab-models DIR] [--unsettled]
--unsettled starts the vehicle-derived rig record at zero deflection instead of the car's static one (the friction's
anchor; `DriveDesign(settled=False)`).
References are kept in --out and reused when present (their solve time is then not measured again).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from nnfmu.data import load_measurement, save_measurement
from nnfmu.data.rigs import DriveDesign, RigOptions, write_rig, write_vehicle_rig
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest import BUSHING_MODELS, RoadTestSettings, monolithic_reference
from nnfmu.workflows.roadtest.bushing_drive import replay_bushing_networks
from nnfmu.workflows.roadtest.systems import bushing_elements, vehicle_components
from nnfmu.workflows.train import TrainRequest, train_from_file

SYSTEM = "full-vehicle"
CHECKED = "bushing_fl_front"  # the road test's open-loop check replays this bushing's motion
TARGET_NRMSE = 0.05


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def reference(out: Path, seed: int, duration: float) -> tuple[Path, float | None]:
    """The full vehicle's monolithic reference on drive `seed`, faded in as the road test's (kept as CSV in `out`;
    None seconds when reused)."""
    fade = RoadTestSettings().fade_in
    path = out / f"reference-seed{seed}-{duration:g}s-fade{fade:g}s.csv"
    if path.is_file():
        log(f"reusing {path}")
        return path, None
    drive = generate_drive(DriveSettings(seed=seed, duration=duration + 1e-3, sample_rate=1000.0, fade_in=fade))
    solved = monolithic_reference(SYSTEM, drive, vehicle_components(SYSTEM))
    log(f"reference on drive seed {seed}: {duration:g} s solved in {solved.seconds:.0f} s")
    return save_measurement(solved.measurement, path), solved.seconds


def train_set(record: Path, folder: Path, reuse: Path | None) -> tuple[dict[str, Path], dict[str, dict]]:
    """The four bushing presets trained with their defaults on `record` (or taken from `reuse`)."""
    models, described = {}, {}
    for preset in BUSHING_MODELS:
        if reuse is not None:
            models[preset] = reuse / f"{preset}.onnx"
            described[preset] = {"reused": str(models[preset])}
            continue
        trained = train_from_file(record, TrainRequest(preset=preset), folder / f"{preset}.onnx")
        models[preset] = trained.path
        described[preset] = {
            "train_s": round(trained.seconds, 1),
            "hidden": trained.model.settings["hidden"],
            "test_split_nrmse": trained.metrics["test"].nrmse,
        }
        log(f"{preset} on {record.name}: {trained.seconds:.0f} s, test-split NRMSE {trained.metrics['test'].nrmse:.4f}")
    return models, described


def judged(models: dict[str, Path], held_out: Path, folder: Path) -> dict[str, object]:
    """NRMSE per channel along each front LCA bushing's held-out motion and the largest envelope use per input."""
    replay = replay_bushing_networks(models, load_measurement(held_out), bushing_elements(SYSTEM), folder)
    envelope: dict[str, float] = {}
    for e in replay.excursions:
        envelope[e.port] = max(envelope.get(e.port, 0.0), e.range_used)
    return {
        "nrmse": {
            element: {c.name.removeprefix(f"{element}_"): c.metrics.nrmse for c in comparisons}
            for element, comparisons in replay.comparisons.items()
        },
        "mean_shift": {c.name.removeprefix(f"{CHECKED}_"): c.metrics.mean_shift for c in replay.comparisons[CHECKED]},
        "largest_envelope_use": envelope,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("bench-out/bushing_drive"))
    parser.add_argument("--duration", type=float, default=50.0, help="length of both references [s]")
    parser.add_argument("--source-seed", type=int, default=1)
    parser.add_argument("--heldout-seed", type=int, default=0)
    parser.add_argument("--rig-duration", type=float, default=60.0)
    parser.add_argument("--margin", type=float, default=1.2)
    parser.add_argument(
        "--elements",
        nargs="+",
        default=bushing_elements(SYSTEM),
        help="bushings the drive is derived from (default: all four front LCA bushings)",
    )
    parser.add_argument("--lab-models", type=Path, help="folder with the lab-trained bushing-*.onnx to reuse")
    parser.add_argument(
        "--unsettled",
        action="store_true",
        help="start the rig record at zero deflection, not at the car's static deflection",
    )
    args = parser.parse_args(argv)
    if args.source_seed == args.heldout_seed:
        parser.error("the held-out drive must differ from the source drive")
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    source, source_s = reference(out, args.source_seed, args.duration)
    held_out, held_out_s = reference(out, args.heldout_seed, args.duration)
    lab_record, _ = write_rig("bushing", out / "lab" / "bushing_lab.csv", RigOptions(seed=0))
    started = time.perf_counter()
    vehicle_record, truth = write_vehicle_rig(
        source,
        args.elements,
        out / "vehicle" / "bushing_vehicle.csv",
        RigOptions(seed=0, duration=args.rig_duration),
        DriveDesign(margin=args.margin, settled=not args.unsettled),
    )
    rig_s = time.perf_counter() - started
    lab_models, lab_training = train_set(lab_record, out / "lab", args.lab_models)
    vehicle_models, vehicle_training = train_set(vehicle_record, out / "vehicle", None)
    before = judged(lab_models, held_out, out / "lab")
    after = judged(vehicle_models, held_out, out / "vehicle")
    design = json.loads(truth.read_text())
    drives = design["excitation"]["drives"]
    checked = after["nrmse"][CHECKED]
    print(
        json.dumps(
            {
                "benchmark": "bushing networks: lab rig record vs vehicle-derived rig record, open loop along a "
                "held-out car motion against the truth physics",
                "settings": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
                "reference_s": {"source": source_s, "held_out": held_out_s},
                "rig_design_s": round(rig_s, 2),
                "rig_design": {
                    key: {
                        k: c[k]
                        for k in (
                            "unit",
                            "start",
                            "working_point",
                            "target_low",
                            "target_high",
                            "designed",
                            "designed_rms_over_simulated_rms",
                            "simulated_variance_outside_band",
                        )
                    }
                    | {"simulated": c["simulated"][args.elements[0]]}
                    for key, c in drives["channels"].items()
                },
                "sensors_full_scale": {
                    name: {"test": s["full_scale"], "rig_default": s["rig_default_full_scale"]}
                    for name, s in design["sensors"].items()
                },
                "training": {"lab": lab_training, "vehicle": vehicle_training},
                "heldout": {"lab": before, "vehicle": after},
                "checked_element": CHECKED,
                "nrmse_lab_vs_vehicle": {
                    channel: [before["nrmse"][CHECKED][channel], value] for channel, value in checked.items()
                },
                "target_nrmse": TARGET_NRMSE,
                "pass": all(value <= TARGET_NRMSE for value in checked.values()),
            }
        )
    )


if __name__ == "__main__":
    main()
