"""`nnfmu loop vehicle` is reached as two words beside the component loop, which keeps its own arguments."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from nnfmu.cli import app


def test_loop_vehicle_is_its_own_command_and_the_component_loop_is_unchanged(tmp_path: Path) -> None:
    runner = CliRunner()
    vehicle = runner.invoke(app, ["loop", "vehicle", "--help"])
    assert vehicle.exit_code == 0 and "--system" in vehicle.output and "--drive" in vehicle.output
    component = runner.invoke(app, ["loop", "--help"])
    assert component.exit_code == 0 and "--model" in component.output and "--system" not in component.output


def test_a_malformed_model_option_is_refused_by_name(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app,
        ["loop", "vehicle", "x.csv", "--system", "s.ssd", "--drive", "d.csv", "--out", str(tmp_path / "o")]
        + ["--model", "damper_fl"],
    )
    assert result.exit_code == 2 and "ELEMENT=PATH.onnx" in result.output
