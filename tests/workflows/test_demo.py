"""`nnfmu demo --quick` runs every stage end to end and writes the report and summary it announces."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from nnfmu.data.rigs import DamperDyno
from nnfmu.fmu.check import check_fmu
from nnfmu.workflows.demo import PRESETS_BY_RIG, UNDECLARED_EFFECTS, DemoSettings, run_demo

pytestmark = pytest.mark.slow


def test_quick_demo_runs_every_stage(tmp_path: Path) -> None:
    lines: list[str] = []
    summary = run_demo(tmp_path, DemoSettings(quick=True, side_lanes=True), log=lines.append)
    # it says what it is at the start, stamps every line with the elapsed time and times every stage
    assert lines[0].startswith("[0:00] quick run:") and all(line.startswith("[") for line in lines)
    # the component networks and the component loop need nothing the other stages make: each runs in a child process
    # of its own beside the rest (as in a full run; a quick one's default is one child for both), their log lines reach
    # the caller, and their stages' times are kept apart
    stages = ["vehicle-derived bushing networks", "vehicle-derived damper networks", "road test", "vehicle loop"]
    stages += ["drive iteration", "waiting for component networks and component loop"]
    beside = ["component networks (own process)", "component loop (own process)"]
    assert list(summary.stage_seconds) == [*stages, *beside] and all(s > 0 for s in summary.stage_seconds.values())
    assert sum(summary.stage_seconds[s] for s in stages) <= summary.seconds
    # the two children run at once, beside each other too: each fits in the run's wall time, their sum need not
    assert all(summary.stage_seconds[s] <= summary.seconds for s in beside)
    assert any(line.endswith("started each in a child process of its own beside the other stages") for line in lines)
    assert any("damper-spline: FMU" in line for line in lines) and any("effects added" in line for line in lines)
    presets = [p for group in PRESETS_BY_RIG.values() for p in group]
    assert [m.preset for m in summary.models] == presets
    for model in summary.models:
        assert Path(model.onnx).exists() and Path(model.fmu).exists()
        # even a smoke-trained network must beat predicting zero on held-out data
        assert np.isfinite(model.replay_nrmse) and model.replay_nrmse < 0.5
        # each characterised beside its lab record's sine series and beside the truth physics' at the same levels,
        # recorded without noise, every point judged against its own error
        name = "dynamic_stiffness.csv" if "bushing" in model.preset else "characteristic.csv"
        tables = {}
        for report, within in (
            (model.characterisation, model.within_own_error),
            (model.truth_characterisation, model.within_own_error_of_truth),
        ):
            with (Path(report).parent / name).open(encoding="utf-8") as stream:
                rows = list(csv.DictReader(stream))
            inside = [row for row in rows if row["training_envelope"] == "inside"]
            assert inside and all(row["within_own_error"] in ("yes", "no") for row in inside)
            assert within == (sum(row["within_own_error"] == "yes" for row in inside), len(inside))
            tables[report] = rows
        lab, truth = tables.values()
        assert len(lab) == len(truth)  # the same series; the truth's read without noise
        if "damper" in model.preset:
            speeds = [float(row["measured_peak_velocity [m/s]"]) for row in truth]
            assert speeds == pytest.approx(DamperDyno().peak_velocities, rel=1e-3)
    assert summary.report.name == "index.html" and summary.report.exists()
    written = json.loads((tmp_path / "summary.json").read_text())
    assert [m["preset"] for m in written["models"]] == presets
    assert written["quick"] is True and list(written["stage_seconds"]) == [*stages, *beside]
    assert sorted(summary.road_test) == ["full-vehicle", "quarter-car"]
    assert all(path.is_file() for path in summary.road_test.values())
    bushings = written["road_test"]["bushing_networks"]  # trained on a rig record derived from the car's deflections
    assert summary.vehicle_bushings is not None and bushings["trained_on"] == str(summary.vehicle_bushings.rig)
    assert all(Path(path).is_file() and "vehicle_bushing" in path for path in bushings["models"].values())
    dampers = written["road_test"]["damper_networks"]  # on a dyno record whose stroke follows the car's dampers
    assert summary.vehicle_dampers is not None and dampers["trained_on"] == str(summary.vehicle_dampers.rig)
    assert dampers["source_reference"] == bushings["source_reference"]
    assert all(Path(path).is_file() and "vehicle_damper" in path for path in dampers["models"].values())
    # the lab's drive iteration on the virtual car: the drive written is what nnfmu cosim reads, and the iterations
    # bring the car's responses towards the road record (the truth reference's sensors)
    iterate = written["iterate"]
    assert Path(iterate["drive"]).is_file() and Path(iterate["report"]).is_file()
    runs = summary.iteration.outcome.iterations
    worst = [max(run.metrics[c]["nrmse"] for c in summary.iteration.channels) for run in runs]
    assert len(runs) == iterate["iterations"] >= 2 and min(worst[1:]) < worst[0], worst
    road = json.loads(Path(written["road_test"]["summary"]).read_text())
    quarter = road["systems"][0]
    assert quarter["system"] == "quarter-car"
    rows = {(r["channel"], r["model"]): r for r in quarter["thesis_table"]}
    for model in ("damper-spline", "damper-hysteresis"):
        # the co-simulated quarter car with a smoke-trained damper network stays near the truth-physics reference
        assert 0.0 <= rows[("damper_displacement", model)]["nrmse"] < 0.5
    loop = written["loop"]
    assert Path(loop["report"]).is_file()
    assert summary.loop.fmu.is_file() and summary.loop.onnx.is_file()
    # the demo's damper has an undeclared gas spring and warming oil; the loop adds only effects that are there
    assert loop["effects_added"] and set(loop["effects_added"]) <= set(UNDECLARED_EFFECTS)
    assert loop["error_after"]["nrmse"] < loop["error_before"]["nrmse"]
    # every network FMU the demo hands over carries its reference results and passes them (nnfmu check)
    for fmu in [Path(m.fmu) for m in summary.models] + [summary.loop.fmu]:
        report = check_fmu(fmu)
        assert report.passed and report.experiments, (fmu, report.checksum_errors, report.experiments)
    # it ends with the thesis's residual one level up: a lab car with gas force the dyno record never showed
    vehicle = written["vehicle_loop"]
    assert Path(vehicle["report"]).is_file() and Path(vehicle["lab_car"]).is_file()
    assert [(i["component"], i["effect"]) for i in vehicle["iterations"]] == [("damper", "gas_force")]
    force = summary.vehicle_loop.channels["damper_force"]
    assert abs(force["after"].mean_shift) < abs(force["before"].mean_shift) / 3
