"""`nnfmu loop vehicle` is reached as two words beside the component loop, which keeps its own arguments."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.cosim.ssp import connect_by_name, write_ssd
from nnfmu.data import Measurement, save_measurement
from nnfmu.data.drive_files import read_drive
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.workflows.vehicle_loop.residuals import ChannelError
from nnfmu.workflows.vehicle_loop.run import verdict


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


@pytest.fixture(scope="module")
def quarter_car(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A quarter car with a linear damper (its step graph beside its FMU) and a 3 s drive."""
    folder = tmp_path_factory.mktemp("loop-vehicle")
    runner = CliRunner()
    for args in (
        ["vehicle", "build", "quarter-car", "--out", folder / "car.fmu", "--sample-period", "1e-3"],
        ["drive", "generate", "--out", folder / "drive.csv", "--duration", "3"],
    ):
        assert runner.invoke(app, [str(a) for a in args]).exit_code == 0
    onnx.save(linear_damper_graph(2400.0, name="damper"), folder / "damper.onnx")
    assert (
        runner.invoke(app, ["build", str(folder / "damper.onnx"), "--out", str(folder / "damper.fmu")]).exit_code == 0
    )
    connected = connect_by_name(
        "quarter car", ("vehicle", folder / "car.fmu"), {"damper": folder / "damper.fmu"}, folder
    )
    return write_ssd(connected, folder / "SystemStructure.ssd")


def lab_record(system: Path, path: Path, start: float) -> Path:
    """A record of damper force and stroke on the drive's sample period, its time axis starting at `start` [s]."""
    drive = read_drive(system.parent / "drive.csv")
    rng = np.random.default_rng(0)
    n = len(drive.time)
    channels = {"damper_force": rng.normal(0, 100, n), "damper_displacement": rng.normal(0, 0.01, n)}
    return save_measurement(
        Measurement.uniform(start, drive.sample_period, channels, {"damper_force": "N", "damper_displacement": "m"}),
        path,
    )


def loop_vehicle(system: Path, record: Path, out: Path, *extra: str):
    args = ["loop", "vehicle", record, "--system", system, "--drive", system.parent / "drive.csv", "--out", out]
    return CliRunner().invoke(app, [str(a) for a in [*args, *extra]])


def test_a_record_whose_time_starts_after_the_drive_is_refused_naming_both(quarter_car: Path, tmp_path: Path) -> None:
    """A record stamped from 1 s against a drive from 0 s compared instants 1 s apart (a record from 3 s was called
    consistent with the error budget at 149 % NRMSE)."""
    result = loop_vehicle(quarter_car, lab_record(quarter_car, tmp_path / "late.csv", 1.0), tmp_path / "out")
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert result.output.startswith("error: "), result.output
    for words in ("late.csv", "drive.csv", "starts at 1 s", "at 0 s"):
        assert words in result.output, result.output
    assert not (tmp_path / "out").exists()


def test_a_garbage_step_graph_is_refused_naming_element_and_file(quarter_car: Path, tmp_path: Path) -> None:
    garbage = tmp_path / "garbage.onnx"
    garbage.write_bytes(b"not an onnx model\n" * 10)
    record = lab_record(quarter_car, tmp_path / "lab.csv", 0.0)
    result = loop_vehicle(quarter_car, record, tmp_path / "out", "--model", f"damper={garbage}")
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert result.output.startswith("error: ") and "'damper'" in result.output and "garbage.onnx" in result.output
    assert not (tmp_path / "out").exists()


def error(nrmse: float) -> ChannelError:
    return ChannelError(nrmse, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0)


def test_an_unexplained_residual_beyond_the_budget_is_never_called_consistent() -> None:
    small = {"damper_force": error(0.03), "body_acceleration": error(0.05)}
    assert "consistent with the co-simulation error budget" in verdict([], small, small, 0.25)
    assert "NOT" not in verdict([], small, small, 0.25)
    large = {"damper_force": error(1.49), "body_acceleration": error(0.05)}
    words = verdict([], large, large, 0.25)
    assert words.startswith("nothing added; NOT consistent") and "damper_force 149%" in words, words
    assert "body_acceleration" not in words and "budget 25%" in words


def test_an_attribution_past_the_memory_limit_is_refused_before_the_sensitivities(
    quarter_car: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The attribution's designs grow with samples x channels x candidates (a sensor offset per channel: with the
    square of the channels); a record past the limit is refused after the first replay, before the sensitivity
    FMUs are built and replayed, naming the sizes (here the limit is lowered to the quarter car's 0.5 MB)."""
    import nnfmu.workflows.vehicle_loop.run as run

    monkeypatch.setattr(run, "MAX_ATTRIBUTION_BYTES", 100_000)
    result = loop_vehicle(quarter_car, lab_record(quarter_car, tmp_path / "lab.csv", 0.0), tmp_path / "out")
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert "sensitivity of the channels" not in result.output
    for words in ("lab.csv", "1500 samples of 2 channels", "3 candidate", "GiB to attribute"):
        assert words in result.output, result.output
    assert not (tmp_path / "out").exists()
