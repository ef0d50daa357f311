"""Careless sizes and values on the command line end in one `error:` line naming the value and the limit, before
anything large is allocated or any file is replaced: never a MemoryError or another traceback."""

from __future__ import annotations

import os
import resource
from pathlib import Path

import onnx
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.cosim.ssp import connect_by_name, write_ssd
from nnfmu.data.drive_files import read_drive, write_drive
from nnfmu.export.linear_damper import linear_damper_graph

runner = CliRunner()


def invoke(*args: object):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(autouse=True)
def bounded_memory():
    """A 4 GiB address-space cap, so that a missing check fails the test with a MemoryError instead of swapping."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = 4 * 1024**3 + resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    resource.setrlimit(resource.RLIMIT_AS, (min(cap, hard) if hard != resource.RLIM_INFINITY else cap, hard))
    yield
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def refused(result, *words: str) -> None:
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert result.output.strip().startswith("error: "), result.output
    for word in words:
        assert word in result.output, result.output


@pytest.fixture(scope="module")
def system(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A quarter car with a linear damper, the damper's filter start value given in the SSD, and a 1 s drive."""
    folder = tmp_path_factory.mktemp("limits")
    assert (
        invoke("vehicle", "build", "quarter-car", "--out", folder / "car.fmu", "--sample-period", "1e-3").exit_code == 0
    )
    onnx.save(linear_damper_graph(2400.0, name="damper"), folder / "damper.onnx")
    assert invoke("build", folder / "damper.onnx", "--out", folder / "damper.fmu").exit_code == 0
    assert invoke("drive", "generate", "--out", folder / "drive.csv", "--duration", "1").exit_code == 0
    connected = connect_by_name(
        "quarter car",
        ("vehicle", folder / "car.fmu"),
        {"damper": folder / "damper.fmu"},
        folder,
        {"damper": {"filter_cutoff": 0.0}},
    )
    return write_ssd(connected, folder / "SystemStructure.ssd")


def test_rig_and_drive_durations_past_the_sample_limit_are_refused(tmp_path: Path) -> None:
    refused(invoke("rig", "damper", "--out", tmp_path / "d.csv", "--duration", "1e9"), "1e+09", "samples", "limit")
    refused(invoke("rig", "bushing", "--out", tmp_path / "b.csv", "--sample-rate", "1e12"), "samples", "limit")
    refused(invoke("drive", "generate", "--out", tmp_path / "r.csv", "--duration", "1e9"), "1e+09", "samples", "limit")
    refused(invoke("drive", "generate", "--out", tmp_path / "r.csv", "--speed", "1e-9"), "samples", "limit")
    assert list(tmp_path.iterdir()) == []


def test_a_hidden_size_past_the_limit_is_refused_before_training(system: Path, tmp_path: Path) -> None:
    data = tmp_path / "dyno.csv"
    assert invoke("rig", "damper", "--out", data, "--duration", "20", "--excitation", "random").exit_code == 0
    refused(
        invoke(
            "train",
            data,
            "--preset",
            "damper-spline",
            "--out",
            tmp_path / "m.onnx",
            "--hidden",
            "100000",
            "--max-epochs",
            "1",
        ),
        "100000",
        "hidden",
        "limit",
    )
    assert not (tmp_path / "m.onnx").exists()


@pytest.mark.parametrize("master", ["fmpy", "libcosim"])
def test_a_result_past_the_size_limit_is_refused_before_the_run(system: Path, tmp_path: Path, master: str) -> None:
    plain = ("--scheme", "jacobi", "--no-extrapolate", "--no-refresh") if master == "libcosim" else ()
    result = invoke(
        "cosim",
        system,
        "--drive",
        system.parent / "drive.csv",
        "--out",
        tmp_path / "r.csv",
        "--step",
        "1e-9",
        "--stop",
        "0.9",
        "--master",
        master,
        *plain,
    )
    refused(result, "900000000 steps", "limit")
    assert not (tmp_path / "r.csv").exists()


def test_a_parameter_that_is_not_finite_is_refused_naming_element_and_parameter(system: Path, tmp_path: Path) -> None:
    text = system.read_text(encoding="utf-8")
    for value in ("nan", "inf", "-INF"):
        odd = system.with_name(f"odd_{value}.ssd")
        assert text.count('value="0.0"') == 1
        odd.write_text(text.replace('value="0.0"', f'value="{value}"'), encoding="utf-8")
        refused(
            invoke("cosim", odd, "--drive", system.parent / "drive.csv", "--out", tmp_path / "r.csv"),
            "element 'damper'",
            "parameter 'filter_cutoff'",
            value,
        )


def test_a_parameter_outside_its_declared_range_is_refused_before_the_run(system: Path, tmp_path: Path) -> None:
    """filter_cutoff declares min 0 in the network FMU: -5 Hz is refused naming element, parameter and bound."""
    odd = system.with_name("odd_negative.ssd")
    odd.write_text(system.read_text(encoding="utf-8").replace('value="0.0"', 'value="-5.0"'), encoding="utf-8")
    refused(
        invoke("cosim", odd, "--drive", system.parent / "drive.csv", "--out", tmp_path / "r.csv"),
        "element 'damper'",
        "parameter 'filter_cutoff' = -5.0",
        "min 0",
    )


@pytest.mark.parametrize("master", ["fmpy", "libcosim"])
def test_an_output_gain_that_overflows_the_output_is_one_error_line(system: Path, tmp_path: Path, master: str) -> None:
    """output_gain = 1e308 is finite but makes the damper force inf: the FMU refuses the sample and the run ends in
    one error line (it was a traceback with fmpy and SIGABRT with libcosim), with no result written."""
    odd = system.with_name(f"odd_gain_{master}.ssd")
    text = system.read_text(encoding="utf-8").replace('name="filter_cutoff"', 'name="output_gain"')
    odd.write_text(text.replace('value="0.0"', 'value="1e308"'), encoding="utf-8")
    plain = ("--scheme", "jacobi", "--no-extrapolate", "--no-refresh") if master == "libcosim" else ()
    result = invoke(
        "cosim", odd, "--drive", system.parent / "drive.csv", "--out", tmp_path / "r.csv", "--master", master, *plain
    )
    refused(result, "odd_gain" if master == "libcosim" else "output_gain")
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.parametrize("delta_t", [b"1.0e300", b"1.0e-300"])
def test_an_rpc_drive_with_an_absurd_time_step_is_one_error_line(system: Path, tmp_path: Path, delta_t: bytes) -> None:
    """DELTA_T 1e300 was an OverflowError traceback in cosim, 1e-300 a ZeroDivisionError."""
    rsp = write_drive(read_drive(system.parent / "drive.csv"), tmp_path / "drive.rsp")
    data = bytearray(rsp.read_bytes())
    at = data.index(b"DELTA_T")
    data[at + 32 : at + 128] = delta_t.ljust(96, b"\0")
    rsp.write_bytes(bytes(data))
    result = invoke("cosim", system, "--drive", rsp, "--out", tmp_path / "r.csv")
    refused(result, "drive.rsp", "DELTA_T", delta_t.decode())
    assert not (tmp_path / "r.csv").exists()


def test_rig_leaves_the_old_data_when_the_truth_file_cannot_be_written(tmp_path: Path) -> None:
    data = tmp_path / "dyno.csv"
    made = invoke("rig", "damper", "--out", data, "--duration", "20", "--seed", "1", "--excitation", "random")
    assert made.exit_code == 0, made.output
    before = data.read_bytes(), data.with_name("dyno.truth.json").read_bytes()
    data.with_name("dyno.truth.json").unlink()
    data.with_name("dyno.truth.json").mkdir()  # the truth file's name is taken by a folder
    refused(
        invoke("rig", "damper", "--out", data, "--duration", "20", "--seed", "2", "--excitation", "random"),
        "dyno.truth.json",
    )
    assert data.read_bytes() == before[0]
    # a name whose data file (and its temporary) fits the file system's 255 bytes but whose truth file's does not
    long = tmp_path / ("x" * 235 + ".csv")
    refused(invoke("rig", "damper", "--out", long, "--duration", "20", "--excitation", "random"), "truth")
    assert not long.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dyno.csv", "dyno.truth.json"]


def test_a_step_that_is_not_a_number_and_negative_iterations_are_refused(system: Path, tmp_path: Path) -> None:
    drive = system.parent / "drive.csv"
    refused(invoke("cosim", system, "--drive", drive, "--out", tmp_path / "r.csv", "--step", "nan"), "step nan")
    refused(
        invoke("cosim", system, "--drive", drive, "--out", tmp_path / "r.csv", "--iterations", "-3"), "iterations -3"
    )


def test_fmus_outside_the_systems_folder_run_only_with_allow_outside(system: Path, tmp_path: Path) -> None:
    """A plain .ssd naming FMUs elsewhere (here by absolute path) is refused naming the element and the option; the
    option runs it."""
    text = system.read_text(encoding="utf-8")
    for name in ("car.fmu", "damper.fmu"):
        assert f'source="{name}"' in text
        text = text.replace(f'source="{name}"', f'source="{system.parent / name}"')
    (tmp_path / "elsewhere").mkdir()
    ssd = tmp_path / "elsewhere" / "SystemStructure.ssd"
    ssd.write_text(text, encoding="utf-8")
    args = ("cosim", ssd, "--drive", system.parent / "drive.csv", "--out", tmp_path / "r.csv")
    refused(invoke(*args), "element 'vehicle'", "outside the system's folder", "--allow-outside")
    assert not (tmp_path / "r.csv").exists()
    allowed = invoke(*args, "--allow-outside")
    assert allowed.exit_code == 0, allowed.output
    assert (tmp_path / "r.csv").is_file()


def test_a_campaign_naming_files_outside_its_folder_runs_only_with_allow_outside(system: Path, tmp_path: Path) -> None:
    (tmp_path / "sys").mkdir()
    for name in ("car.fmu", "damper.fmu", "SystemStructure.ssd"):
        os.link(system.parent / name, tmp_path / "sys" / name)
    campaign = tmp_path / "campaign.toml"
    campaign.write_text(
        '[[events]]\nname = "lab"\ndrive = "/etc/passwd"\n'
        '[[variants]]\nname = "linear"\nsystem = "sys/SystemStructure.ssd"\n',
        encoding="utf-8",
    )
    refused(invoke("batch", campaign, "--out", tmp_path / "out", "--workers", "0"), "/etc/passwd", "--allow-outside")
    assert not (tmp_path / "out").exists()
    campaign.write_text(
        f'[drive]\nduration = 1.0\n[[events]]\nname = "C"\nclass = "C"\nspeed = 20.0\n'
        f'[[variants]]\nname = "linear"\nsystem = "{system}"\n',
        encoding="utf-8",
    )
    refused(invoke("batch", campaign, "--out", tmp_path / "out", "--workers", "0"), "variant 'linear'", "outside")
    allowed = invoke("batch", campaign, "--out", tmp_path / "out", "--workers", "0", "--allow-outside")
    assert allowed.exit_code == 0 and "1 cases: 1 ok" in allowed.output, allowed.output
