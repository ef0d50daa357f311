"""The road test, a campaign and the vehicle loop at small settings on fixed inputs, their figures as JSON, and a
bit-for-bit comparison of two such runs (issue 35: the system object must leave every figure unchanged).

Usage:
  python bench/system_figures.py run FIXTURES OUT [road_test|campaign|vehicle_loop ...]
      # trains FIXTURES/models and builds the campaign's FMUs once (reused after), writes OUT/<use case>.json
  python bench/system_figures.py compare BEFORE AFTER # exit status 1 and the differing keys where any figure differs

Every run writes into the same scratch folder (FIXTURES/run), so the paths the outputs record are the same; run
times, which differ between runs, are taken out of the figures (`TIMINGS`). The CSV and parquet results are
included as their sha256, so a changed sample anywhere shows.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import sys
from pathlib import Path
from typing import Any

TIMINGS = {"seconds", "wall_s", "started", "finished", "created", "elapsed_s", "versions", "engine", "run_s"}


def _strip(value: Any) -> Any:
    """`value` without the keys of run times (recursively)."""
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if k not in TIMINGS}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


def _digests(folder: Path, pattern: str) -> dict[str, str]:
    """sha256 of every file matching `pattern` under `folder`, by relative path."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.glob(pattern))
    }


def models(fixtures: Path) -> dict[str, Path]:
    """The two damper networks, trained small once into `fixtures/models` and reused."""
    from nnfmu.data.rigs import RigOptions, write_rig
    from nnfmu.workflows.train import TrainRequest, train_from_file

    folder = fixtures / "models"
    found = {}
    for preset in ("damper-spline", "damper-hysteresis"):
        path = folder / f"{preset}.onnx"
        if not path.is_file():
            dyno = folder / "dyno.csv"
            if not dyno.is_file():
                write_rig("damper", dyno, RigOptions(duration=20.0, excitation="random", noise=0.5, seed=0))
            request = TrainRequest(preset=preset, restarts=1, max_epochs=150, hidden=(8,), moving_mass=2.0)
            train_from_file(dyno, request, path)
        found[preset] = path
    return found


def road_test(fixtures: Path, scratch: Path) -> dict[str, Any]:
    """The quarter car's road test over 3 s, no characterisation."""
    from nnfmu.workflows.roadtest import RoadTestSettings, SystemRun, run_road_test

    out = scratch / "roadtest"
    settings = RoadTestSettings(quarter_car=SystemRun(3.0), full_vehicle=None, window=(1.0, 2.0), characterise=None)
    result = run_road_test(out, models(fixtures), settings, log=lambda _: None)
    figures = json.loads(Path(result.summary).read_text())
    return {"road_test.json": figures, "csv": _digests(out, "results/**/*.csv")}


def campaign(fixtures: Path, scratch: Path) -> dict[str, Any]:
    """Two generated 1 s events x two damper variants (one a swapped FMU) of the campaigns' quarter car, serially;
    its FMUs built once into `fixtures/campaign` (an FMU's bytes, which the case keys hash, differ per build)."""
    import pyarrow.parquet as pq

    from nnfmu.workflows.campaign import run_campaign
    from nnfmu.workflows.campaign.quarter_car import build_quarter_car_system

    built = fixtures / "campaign"
    if not (built / "SystemStructure.ssd").is_file():
        build_quarter_car_system(built, {"linear": 2400.0, "firm": 3600.0})
    folder = scratch / "campaign"
    shutil.copytree(built, folder / "inputs")
    variants = "".join(
        f'[[variants]]\nname = "{name}"\nsystem = "inputs/SystemStructure.ssd"\n'
        f'fmus = {{ damper = "inputs/damper-{name}.fmu" }}\n'
        for name in ("linear", "firm")
    )
    text = (
        'name = "figures"\n[coupling]\nstep = 1e-3\n'
        '[metrics]\nchannels = ["damper_force", "body_acceleration"]\nreference = "linear"\n'
        '[drive]\nduration = 1.0\n[[events]]\nname = "C-20"\nclass = "C"\nspeed = 20.0\nrepeats = 2\n' + variants
    )
    (folder / "campaign.toml").write_text(text)
    run_campaign(folder / "campaign.toml", folder / "out", workers=0)
    table = pq.read_table(folder / "out" / "results.parquet").to_pylist()
    record = json.loads((folder / "out" / "campaign.json").read_text())
    del record["run"]["table"]["sha256"]  # the table's bytes hold each case's wall time; its rows are compared above
    return {"results": _strip(table), "campaign.json": _strip(record)}


def vehicle_loop(fixtures: Path, scratch: Path) -> dict[str, Any]:
    """The quarter car's vehicle loop on an 8 s lab car with a gas force, the hysteresis network's FMU as its damper."""
    from nnfmu.data.drive_files import read_drive, write_drive
    from nnfmu.fmu import BuildOptions, build_fmu
    from nnfmu.vehicle import DriveSettings, generate_drive
    from nnfmu.workflows.loop import LoopSettings
    from nnfmu.workflows.roadtest import build_vehicle, write_system
    from nnfmu.workflows.roadtest.lab_car import LabCar, write_lab_car
    from nnfmu.workflows.vehicle_loop import VehicleLoopSettings, run_vehicle_loop

    folder = scratch / "vehicle_loop"
    damper = build_fmu(
        models(fixtures)["damper-hysteresis"], BuildOptions(out=folder / "fmu" / "damper.fmu", platforms=("linux64",))
    )
    vehicle = build_vehicle("quarter-car", folder / "fmu", 1e-3)
    ssd = write_system("quarter-car", vehicle, damper, None, folder / "system")
    drive = write_drive(generate_drive(DriveSettings(duration=8.001, seed=5)), folder / "drive.csv")
    car = LabCar(system="quarter-car", damper_effects={"damper": ("gas_force",)})
    record = write_lab_car(car, read_drive(drive), folder / "lab.csv")
    settings = VehicleLoopSettings(
        in_situ=LoopSettings(max_effects=1, max_epochs=60, extra_hidden=(0, 4), lm_max_samples=4000, fresh_rival=False)
    )
    run_vehicle_loop(record, ssd, drive, folder / "out", settings, log=lambda _: None)
    return {"report.json": _strip(json.loads((folder / "out" / "report.json").read_text()))}


def run(fixtures: Path, out: Path, only: list[str]) -> None:
    """Every figure (or those of the use cases named in `only`) into `out`/<use case>.json."""
    out.mkdir(parents=True, exist_ok=True)
    scratch = fixtures / "run"
    cases = {
        "road_test": lambda: road_test(fixtures, scratch),
        "campaign": lambda: campaign(fixtures, scratch),
        "vehicle_loop": lambda: vehicle_loop(fixtures, scratch),
    }
    for name, make in cases.items():
        if only and name not in only:
            continue
        shutil.rmtree(scratch / name.replace("_test", "test"), ignore_errors=True)
        figures = _strip(make())
        (out / f"{name}.json").write_text(json.dumps(figures, indent=1, sort_keys=True, allow_nan=True))
        print(f"{name}: {out / (name + '.json')}", flush=True)


def _differences(a: Any, b: Any, where: str = "") -> list[str]:
    """The keys at which two JSON values differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b)) for d in _differences(a.get(k), b.get(k), f"{where}/{k}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _differences(x, y, f"{where}[{i}]")]
    return [] if a == b and type(a) is type(b) else [f"{where}: {str(a)[:80]} != {str(b)[:80]}"]


def compare(before: Path, after: Path) -> int:
    """0 when every figure file of `before` has a byte-identical twin in `after`; else 1, the differences printed."""
    status = 0
    for path in sorted(before.glob("*.json")):
        twin = after / path.name
        same = twin.is_file() and twin.read_bytes() == path.read_bytes()
        print(f"{path.name}: {'bit-identical' if same else 'DIFFERS'}")
        if not same:
            status = 1
            if twin.is_file():
                for line in _differences(json.loads(path.read_text()), json.loads(twin.read_text()))[:20]:
                    print(f"  {line}")
    return status


if __name__ == "__main__":
    if len(sys.argv) < 4 or sys.argv[1] not in ("run", "compare") or sys.argv[1] == "compare" and len(sys.argv) > 4:
        sys.exit(__doc__)
    if sys.argv[1] == "run":
        run(Path(sys.argv[2]), Path(sys.argv[3]), sys.argv[4:])
    else:
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
