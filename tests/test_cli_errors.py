"""The command line reports an NnfmuError as one `error:` line with exit status 2 and nothing else: a programming
error inside a command (a plain ValueError included) keeps its traceback instead of passing for the user's mistake."""

from __future__ import annotations

from pathlib import Path

import onnx
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.component import METADATA_KEY, replace_metadata
from nnfmu.errors import SettingsError
from nnfmu.export.linear_damper import linear_damper_graph

runner = CliRunner()

# (command line with {tmp} for the test's folder, the function the command calls: module, name)
COMMANDS = {
    "rig": (["rig", "damper", "--out", "{tmp}/d.csv"], ("nnfmu.workflows.rig", "write_rig_record")),
    "train": (
        ["train", "{tmp}/d.csv", "--preset", "damper-spline", "--out", "{tmp}/m.onnx"],
        ("nnfmu.workflows.train", "train_from_file"),
    ),
    "cosim": (
        ["cosim", "{tmp}/system", "--drive", "{tmp}/drive.csv", "--out", "{tmp}/r.csv"],
        ("nnfmu.workflows.cosim", "run_cosim"),
    ),
    "validate": (
        ["validate", "{tmp}/a.csv", "{tmp}/b.csv", "--out", "{tmp}/report"],
        ("nnfmu.workflows.validation", "validate_files"),
    ),
    "data check": (["data", "check", "{tmp}/d.csv"], ("nnfmu.workflows.data_check", "check_data_file")),
    "build": (["build", "{tmp}/m.onnx", "--out", "{tmp}/m.fmu"], ("nnfmu.workflows.fmu_build", "build_fmu")),
    "iterate": (
        ["iterate", "{tmp}/road.csv", "--system", "{tmp}/system", "--out", "{tmp}/out"],
        ("nnfmu.workflows.iterate", "run_iterate"),
    ),
}


def invoke_raising(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, command: str, error: BaseException):
    """Run `command` with the function it calls replaced by one raising `error`."""
    args, (module, name) = COMMANDS[command]

    def broken(*_args: object, **_kwargs: object) -> None:
        raise error

    monkeypatch.setattr(f"{module}.{name}", broken)
    return runner.invoke(app, [a.format(tmp=tmp_path) for a in args])


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize(
    "error",
    [ZeroDivisionError("division by zero"), ValueError("a bug's message")],
    ids=["ZeroDivisionError", "ValueError"],
)
def test_a_programming_error_inside_a_command_propagates(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, command: str, error: Exception
) -> None:
    result = invoke_raising(monkeypatch, tmp_path, command, error)
    assert result.exception is error, result.output
    assert result.exit_code != 2
    assert "error:" not in result.output


@pytest.mark.parametrize("command", COMMANDS)
def test_an_nnfmu_error_inside_a_command_is_one_error_line(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, command: str
) -> None:
    """The control: the same place raising an NnfmuError ends in exit status 2 and its message, no traceback."""
    result = invoke_raising(monkeypatch, tmp_path, command, SettingsError("--knob 7 is out of range"))
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert result.output.strip() == "error: --knob 7 is out of range"


def test_loop_on_a_model_with_malformed_metadata_is_one_error_line(tmp_path: Path) -> None:
    """A user's file that once surfaced as a bare ValueError (and a traceback) is reported as the user's input."""
    model = linear_damper_graph(2400.0, name="damper")
    replace_metadata(model, METADATA_KEY, "[1, 2]")
    onnx.save(model, tmp_path / "odd.onnx")
    data = tmp_path / "dyno.csv"
    assert (
        runner.invoke(
            app, ["rig", "damper", "--out", str(data), "--duration", "20", "--excitation", "random"]
        ).exit_code
        == 0
    )
    result = runner.invoke(
        app, ["loop", str(data), "--model", str(tmp_path / "odd.onnx"), "--out", str(tmp_path / "loop")]
    )
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert result.output.startswith("error: ") and "odd.onnx: cannot read the component description" in result.output
    assert not (tmp_path / "loop").exists()


def test_a_bad_slope_is_named_as_the_help_names_it(tmp_path: Path) -> None:
    """`--slope 1e308` was refused as "Basquin slope for 'basquin_slope'", a name the command line does not have."""
    record = tmp_path / "r.csv"
    record.write_text("time [s],force [N]\n0,1\n0.001,2\n0.002,1\n", encoding="utf-8")
    done = runner.invoke(app, ["validate", str(record), str(record), "--slope", "1e308", "--out", str(tmp_path / "v")])
    assert done.exit_code == 2
    assert "Basquin slope m must be a number in (0, 50], got 1e+308" in done.output
    assert "basquin_slope" not in done.output
    help_text = runner.invoke(app, ["validate", "--help"]).output
    assert "Basquin slope m" in help_text
