"""The command line end to end on small data: each command's exit status, output and files."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.cosim.ssp import connect_by_name, write_ssd
from nnfmu.data import load_measurement

runner = CliRunner()


def invoke(*args: str):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def dyno(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cli") / "dyno.csv"
    result = invoke("rig", "damper", "--out", out, "--duration", "40", "--seed", "3")
    assert result.exit_code == 0, result.output
    return out


def test_rig_writes_data_and_separate_truth(dyno: Path) -> None:
    truth = json.loads(dyno.with_name("dyno.truth.json").read_text())
    assert "hysteresis" in json.dumps(truth)
    assert dyno.read_text().splitlines()[0].startswith("time [s],")


def test_rig_rejects_unknown_effect(tmp_path: Path) -> None:
    result = invoke("rig", "damper", "--out", tmp_path / "x.csv", "--effects", "warp_drive")
    assert result.exit_code == 2
    assert "warp_drive" in result.output
    assert not (tmp_path / "x.csv").exists()


def test_data_check_lists_channels_and_names_missing_ones(dyno: Path) -> None:
    ok = invoke("data", "check", dyno)
    assert ok.exit_code == 0 and "force [N]" in ok.output
    missing = invoke("data", "check", dyno, "--require", "temperature")
    assert missing.exit_code == 2 and "temperature" in missing.output


@pytest.mark.slow
def test_train_build_and_validate_chain(dyno: Path, tmp_path: Path) -> None:
    onnx_path = tmp_path / "damper.onnx"
    trained = invoke(
        "train", dyno, "--preset", "damper-hysteresis", "--out", onnx_path, "--max-epochs", "5", "--restarts", "1"
    )
    assert trained.exit_code == 0, trained.output
    assert "test" in trained.output and onnx_path.exists()
    assert "velocity[k]" in trained.output  # printed as is, not eaten as console markup
    # where the network answers from data: the velocity's range and the band its record held
    assert re.search(r"trained on velocity -?[\d.]+ to [\d.]+ m/s up to [\d.]+ Hz", " ".join(trained.output.split()))
    fmu = tmp_path / "damper.fmu"
    built = invoke("build", onnx_path, "--out", fmu)
    assert built.exit_code == 0, built.output
    assert fmu.exists() and "reference results: yes" in built.output
    assert "step graph: extra/org.nnfmu/model.onnx inside the FMU" in built.output
    checked = invoke("check", fmu)  # the trained network's FMU replays its held-out test inputs
    assert checked.exit_code == 0 and "force: max error" in checked.output, checked.output
    assert "step graph: extra/org.nnfmu/model.onnx (" in checked.output  # its graph, checked against its digest
    report = invoke("validate", dyno, dyno, "--channels", "force", "--out", tmp_path / "report")
    assert report.exit_code == 0, report.output
    assert "NRMSE 0" in report.output and (tmp_path / "report" / "index.html").exists()
    _vehicle_cosim_and_loop_chain(dyno, onnx_path, fmu, tmp_path)


def _vehicle_cosim_and_loop_chain(dyno: Path, onnx_path: Path, damper_fmu: Path, tmp_path: Path) -> None:
    """The damper FMU in a quarter car built by the CLI, co-simulated by both masters on a CLI drive file; then the
    loop's diagnosis of the model on its own dyno record (no effect added: --max-effects 0)."""
    vehicle = tmp_path / "car.fmu"
    built = invoke("vehicle", "build", "quarter-car", "--out", vehicle, "--sample-period", "1e-3")
    assert built.exit_code == 0, built.output
    stabilised = invoke(
        "vehicle",
        "build",
        "full-vehicle",
        "--out",
        tmp_path / "full.fmu",
        "--stabilise",
        "bushing_fl_front,bushing_fl_rear",
    )
    assert stabilised.exit_code == 0 and (tmp_path / "full.fmu").exists(), stabilised.output
    drive = tmp_path / "drive.csv"
    assert invoke("drive", "generate", "--out", drive, "--duration", "2").exit_code == 0
    ssd = write_ssd(
        connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper_fmu}, tmp_path / "system"),
        tmp_path / "system" / "SystemStructure.ssd",
    )
    results = {}
    for master in ("fmpy", "libcosim"):
        out = tmp_path / f"{master}.csv"
        run = invoke(
            "cosim",
            ssd,
            "--drive",
            drive,
            "--out",
            out,
            "--scheme",
            "jacobi",
            "--no-extrapolate",
            "--no-refresh",
            "--master",
            master,
        )
        assert run.exit_code == 0, run.output
        results[master] = load_measurement(out)
    assert "damper_force" in results["fmpy"].names and results["fmpy"].units["damper_force"] == "N"
    for name in ("damper_force", "body_acceleration"):
        scale = np.max(np.abs(results["fmpy"][name]))
        np.testing.assert_allclose(results["libcosim"][name], results["fmpy"][name], rtol=0, atol=1e-6 * scale)
    loop = invoke(
        "loop", dyno, "--model", onnx_path, "--output", "force", "--out", tmp_path / "loop", "--max-effects", "0"
    )
    assert loop.exit_code == 0, loop.output
    assert "effects added: none" in loop.output and (tmp_path / "loop" / "report.json").exists()
    refused = invoke("loop", drive, "--model", onnx_path, "--out", tmp_path / "refused")
    assert refused.exit_code != 0 and "velocity" in refused.output and not (tmp_path / "refused").exists()


@pytest.mark.slow
def test_vehicle_build_takes_a_quarter_car_file_and_refuses_what_does_not_fit(tmp_path: Path) -> None:
    """The packaged quarter-car file builds a quarter car on its own corner; a different corner, or a full vehicle from
    it, is refused naming the file, and no FMU is left."""
    from fmpy import read_model_description

    from nnfmu.vehicle.dynamics.parameters import DEFAULTS_DIR

    quarter = DEFAULTS_DIR / "midsize_sedan_quarter_car_fl.toml"
    out = tmp_path / "qc.fmu"
    built = invoke("vehicle", "build", "quarter-car", "--params", quarter, "--out", out, "--sample-period", "1e-3")
    assert built.exit_code == 0, built.output
    description = read_model_description(str(out))
    assert "(fl corner)" in description.description
    inputs = [v.name for v in description.modelVariables if v.causality == "input"]
    assert inputs == ["actuator_fl_displacement", "actuator_fl_velocity", "damper_force"]
    for args, message in (
        (("quarter-car", "--corner", "fr"), "stands on corner 'fl'"),
        (("full-vehicle",), "a quarter-car parameter file"),
        (("quarter-car", "--corner", "left"), "corner 'left'"),
    ):
        refused = invoke("vehicle", "build", *args, "--params", quarter, "--out", tmp_path / "no.fmu")
        assert refused.exit_code != 0 and message in refused.output, refused.output
        assert str(quarter) in refused.output or "left" in message
        assert not (tmp_path / "no.fmu").exists()
    helped = invoke("vehicle", "build", "--help")
    assert "quarter-car file" in " ".join(helped.output.split()), helped.output


def test_build_failure_exits_nonzero_without_fmu(tmp_path: Path) -> None:
    bad = tmp_path / "bad.onnx"
    bad.write_text("not an onnx file")
    result = invoke("build", bad, "--out", tmp_path / "bad.fmu")
    assert result.exit_code != 0
    assert not (tmp_path / "bad.fmu").exists()


def test_train_rejects_unknown_preset(dyno: Path, tmp_path: Path) -> None:
    result = invoke("train", dyno, "--preset", "nope", "--out", tmp_path / "m.onnx")
    assert result.exit_code == 2 and "known presets" in result.output


def test_drive_generate_and_convert(tmp_path: Path) -> None:
    rsp = tmp_path / "drive.rsp"
    made = invoke("drive", "generate", "--out", rsp, "--duration", "5", "--pothole", "2:0.04")
    assert made.exit_code == 0, made.output
    converted = invoke("drive", "convert", rsp, tmp_path / "drive.csv")
    assert converted.exit_code == 0, converted.output
    assert "actuator_fl_displacement [m]" in (tmp_path / "drive.csv").read_text().splitlines()[0]
