"""`nnfmu controller build`: the skyhook FMU with the chosen command port, and bad options as one `error:` line."""

from __future__ import annotations

from pathlib import Path

import pytest
from fmpy import read_model_description
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.errors import SettingsError

runner = CliRunner()


def _variables(fmu: Path) -> dict[str, tuple[str, str]]:
    return {
        v.name: (v.causality, v.unit or "")
        for v in read_model_description(str(fmu)).modelVariables
        if v.type in ("Real", "Float64")
    }


@pytest.mark.parametrize(
    ("args", "port"), [([], ("voltage", "V")), (["--command", "current", "--fmi", "3"], ("current", "A"))]
)
def test_controller_build_writes_the_skyhook_fmu(tmp_path: Path, args: list[str], port: tuple[str, str]) -> None:
    out = tmp_path / "skyhook.fmu"
    result = runner.invoke(app, ["controller", "build", "skyhook", "--out", str(out), "--c-sky", "5000", *args])
    assert result.exit_code == 0, result.output
    said, binaries = result.output.strip().splitlines()
    assert said == f"FMU: {out}"
    host = "linux64" if "--fmi" not in args else "x86_64-linux"
    assert binaries.startswith("binaries: ") and host in binaries.removeprefix("binaries: ").split(", ")
    variables = _variables(out)
    assert variables["body_velocity"] == ("input", "m/s") and variables["damper_velocity"] == ("input", "m/s")
    assert variables[port[0]] == ("output", port[1])
    assert read_model_description(str(out)).fmiVersion == ("3.0" if "--fmi" in args else "2.0")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["skyhook", "--c-min", "5000"], "error: skyhook c_max 4000.0 N.s/m must be a finite number > 5000"),
        (["skyhook", "--command", "pressure"], "error: unknown damper command 'pressure'; use voltage or current"),
        (
            ["skyhook", "--command-min", "2", "--command-max", "2"],
            "error: command 'voltage': soft and hard command are both 2.0 V; they must differ",
        ),
        (["groundhook"], "error: unknown controller 'groundhook'; use skyhook"),
        (["skyhook", "--fmi", "4"], "error: unsupported FMI version 4; choose 2 or 3"),
    ],
)
def test_bad_options_are_one_error_line_and_write_nothing(tmp_path: Path, args: list[str], message: str) -> None:
    out = tmp_path / "skyhook.fmu"
    result = runner.invoke(app, ["controller", "build", *args, "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert result.output.strip() == message
    assert not out.exists()


@pytest.mark.parametrize("error", [ZeroDivisionError("a bug"), SettingsError("--knob 7 is out of range")])
def test_only_an_nnfmu_error_inside_the_build_becomes_an_error_line(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, error: Exception
) -> None:
    def broken(*_args: object, **_kwargs: object) -> None:
        raise error

    monkeypatch.setattr("nnfmu.workflows.controller.build_controller_fmu", broken)
    result = runner.invoke(app, ["controller", "build", "skyhook", "--out", str(tmp_path / "s.fmu")])
    if isinstance(error, SettingsError):
        assert result.exit_code == 2 and result.output.strip() == "error: --knob 7 is out of range"
    else:
        assert result.exception is error and "error:" not in result.output
