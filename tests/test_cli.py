"""The command line end to end on small data: each command's exit status, output and files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nnfmu.cli import app

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


def test_train_build_and_validate_chain(dyno: Path, tmp_path: Path) -> None:
    onnx_path = tmp_path / "damper.onnx"
    trained = invoke("train", dyno, "--preset", "damper-hysteresis", "--out", onnx_path,
                     "--max-epochs", "5", "--restarts", "1")
    assert trained.exit_code == 0, trained.output
    assert "test" in trained.output and onnx_path.exists()
    fmu = tmp_path / "damper.fmu"
    built = invoke("build", onnx_path, "--out", fmu)
    assert built.exit_code == 0, built.output
    assert fmu.exists()
    report = invoke("validate", dyno, dyno, "--channels", "force", "--out", tmp_path / "report")
    assert report.exit_code == 0, report.output
    assert "NRMSE 0" in report.output and (tmp_path / "report" / "index.html").exists()


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
