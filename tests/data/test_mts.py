"""MTS 793 / TestSuite ASCII exports: synthetic files in the export's layout (written here, no third-party files)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.data import DataError, load_measurement

RATE = 1024.0
INCH = 0.0254
LBF = 0.45359237 * 9.80665
FORMAT_LINE = "MTS793|MPT|ENU|1|2|.|/|:|1|0|0|A"


def _info(start: float) -> str:
    return f"Data Acquisition\t\t\tTime:\t{start:#.8g}\tSec\t3/14/2024 9:12:05 AM"


def write_mts(
    path: Path,
    duration: float = 12.0,
    restart_at: float = 6.0,
    names: tuple[str, ...] = ("Axial Displacement", "Axial Force", "Running Time"),
    units: tuple[str, ...] = ("in", "lbf", "Sec"),
    columns=None,
    second_block_time=None,
    format_line: str = FORMAT_LINE,
) -> tuple[Path, np.ndarray, np.ndarray, np.ndarray]:
    """A dyno record as MTS 793 MPT writes it: tab-separated, 8 significant digits, stroke [in] and load [lbf]
    before the running time [Sec], and the names and units rows repeated where acquisition restarts.

    `columns(t, x, f)` gives each row's cells (default: x, f, t); `second_block_time(t)` rewrites the second block's
    stamps. Returns the path and the exact time, stroke and load.
    """
    t = 5.0 + np.arange(int(duration * RATE)) / RATE  # running time since the test started
    x = 1.5 * np.sin(2 * np.pi * 1.3 * t)
    f = 400.0 * np.cos(2 * np.pi * 1.3 * t)
    columns = columns or (lambda time, stroke, load: (stroke, load, time))
    split = int(restart_at * RATE)
    header = ["\t".join(names), "\t".join(units)]
    lines = [format_line, "", _info(t[0]), *header]
    for i in range(t.size):
        stamp = t[i]
        if i == split:
            lines += ["", _info(t[i]), *header]
        if i >= split and second_block_time is not None:
            stamp = second_block_time(t[i])
        lines.append("\t".join(f"{v:#.8g}" for v in columns(stamp, x[i], f[i])))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path, t, x, f


@pytest.fixture
def dyno(tmp_path: Path):
    return write_mts(tmp_path / "specimen.dat")


def test_export_is_read_in_si_with_blocks_joined(dyno):
    path, t, x, f = dyno
    m = load_measurement(path, required=("force", "velocity"))
    assert len(m) == t.size  # both blocks, joined
    assert m.names[:2] == ["displacement", "force"]
    assert m.units["displacement"] == "m" and m.units["force"] == "N"
    np.testing.assert_allclose(m["displacement"], x * INCH, rtol=0, atol=6e-8 * INCH)  # 8 digits: 1e-7 in above 1 in
    np.testing.assert_allclose(m["force"], f * LBF, rtol=0, atol=1e-5 * LBF)
    np.testing.assert_allclose(m.time, t, rtol=0, atol=1e-9)
    assert abs(m.sample_period - 1 / RATE) < 1e-12
    np.testing.assert_allclose(m["velocity"], 1.5 * INCH * 2 * np.pi * 1.3 * np.cos(2 * np.pi * 1.3 * t), atol=1e-5)
    assert "2 acquisition block(s) from lines 3, 6151, joined" in m.notes["format"]
    assert m.notes["channels"] == (
        "channels read as 'Running Time' [Sec] -> time, 'Axial Displacement' [in] -> displacement, "
        "'Axial Force' [lbf] -> force"
    )
    assert "printed to 8 significant digits" in m.notes["time"]


def test_time_in_the_first_column_and_a_csv_suffix_are_read_too(tmp_path):
    path, t, x, _ = write_mts(
        tmp_path / "export.csv",
        names=("Running Time", "Axial Displacement", "Axial Force"),
        units=("Sec", "mm", "kN"),
        columns=lambda time, stroke, load: (time, stroke, load),
    )
    m = load_measurement(path)
    np.testing.assert_allclose(m["displacement"], x * 1e-3, atol=1e-11)
    assert m.units["force"] == "N"


def test_block_whose_time_restarts_is_refused_naming_the_line(tmp_path):
    path, *_ = write_mts(tmp_path / "restart.dat", second_block_time=lambda time: time - 11.0)
    with pytest.raises(
        DataError,
        match=r"restart\.dat: line 6154: the acquisition block from line 6151 does not continue the time of the "
        r"block before: t = 0 s follows t = 10\.999023 s at line 6149",
    ):
        load_measurement(path)


def test_block_with_other_channels_is_refused_naming_the_line(tmp_path):
    path, *_ = write_mts(tmp_path / "other.dat")
    text = path.read_text().splitlines()
    assert text[6151] == "Axial Displacement\tAxial Force\tRunning Time"  # line 6152: the second names row
    text[6151] = "Axial Displacement\tAxial Load\tRunning Time"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(DataError, match=r"other\.dat: line 6152: the channel names differ from those at line 4"):
        load_measurement(path)


def test_stroke_and_load_are_displacement_and_force_and_counters_are_left_out(tmp_path):
    path, _, x, _ = write_mts(
        tmp_path / "names.txt",
        names=("stroke", "load", "Axial Count", "Running Time"),
        units=("in", "kip", "cycles", "Sec"),
        columns=lambda time, stroke, load: (stroke, load / 1000.0, 7.0, time),
    )
    m = load_measurement(path)
    np.testing.assert_allclose(m["displacement"], x * INCH, atol=1e-9)
    assert "'Axial Count' [cycles] (a unit nnfmu does not know)" in m.notes["channels"]
    assert "axial_count" not in m


def test_two_force_channels_keep_their_axis_and_an_explicit_map_decides(tmp_path):
    path, *_ = write_mts(
        tmp_path / "two.dat",
        names=("Axial Displacement", "Axial Force", "Radial Force", "Running Time"),
        units=("in", "lbf", "lbf", "Sec"),
        columns=lambda time, stroke, load: (stroke, load, -load, time),
    )
    both = load_measurement(path)
    assert {"displacement", "axial_force", "radial_force"} <= set(both.names)
    mapped = load_measurement(path, channel_map={"axial force": "force"})
    np.testing.assert_allclose(mapped["force"], both["axial_force"])
    assert "radial_force" in mapped and "axial_force" not in mapped


def test_same_channel_twice_is_refused_naming_both_columns(tmp_path):
    path, *_ = write_mts(
        tmp_path / "twice.dat",
        names=("Axial Force", "Axial Load", "Running Time"),
        units=("lbf", "lbf", "Sec"),
        columns=lambda time, stroke, load: (load, load, time),
    )
    with pytest.raises(
        DataError,
        match=r"twice\.dat: columns 1 'Axial Force' and 2 'Axial Load' would both be channel 'axial_force'; say "
        r"which is which with a channel map",
    ):
        load_measurement(path)
    m = load_measurement(path, channel_map={"Axial Force": "force"})
    assert {"force", "axial_load"} <= set(m.names)


def test_missing_quantity_lists_the_files_channels(dyno):
    path, *_ = dyno
    with pytest.raises(
        DataError,
        match=r"specimen\.dat: missing required channel\(s\) 'temperature'; channels read as 'Running Time' \[Sec\] "
        r"-> time, 'Axial Displacement' \[in\] -> displacement, 'Axial Force' \[lbf\] -> force; name the file channel",
    ):
        load_measurement(path, required=("force", "temperature"))


def test_map_naming_an_absent_channel_is_refused(dyno):
    path, *_ = dyno
    with pytest.raises(DataError, match=r"channel map names 'Load Cell', which the file does not have; its channels"):
        load_measurement(path, channel_map={"Load Cell": "force"})


@pytest.mark.parametrize(
    ("format_line", "message"),
    [
        ("MTS793|MPT|ENU|1|0|.|/|:|1|0|0|A", r"a space-delimited \('plain'\) MTS export cannot be split"),
        ("MTS793|MPT|ENU|1|7|.|/|:|1|0|0|A", r"unknown delimiter code '7'"),
    ],
)
def test_unreadable_format_line_is_refused(tmp_path, format_line, message):
    path, *_ = write_mts(tmp_path / "fmt.dat", duration=1.0, restart_at=2.0, format_line=format_line)
    with pytest.raises(DataError, match=r"fmt\.dat: line 1: " + message):
        load_measurement(path)


def test_decimal_comma_is_read(tmp_path):
    path, t, _, f = write_mts(
        tmp_path / "comma.dat", duration=1.0, restart_at=2.0, format_line="MTS793|MPT|DEU|1|2|,|.|:|49|1|0|A"
    )
    path.write_text(path.read_text().replace(".", ","))
    m = load_measurement(path)
    np.testing.assert_allclose(m["force"], f * LBF, atol=1e-5 * LBF)


def test_text_in_a_value_names_line_and_channel(dyno):
    path, *_ = dyno
    lines = path.read_text().splitlines()
    lines[9] = lines[9].split("\t")[0] + "\toops\t" + lines[9].split("\t")[2]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"specimen\.dat: line 10, channel 'Axial Force': 'oops' is not a number"):
        load_measurement(path)


def test_dat_file_that_is_not_an_export_is_refused(tmp_path):
    path = tmp_path / "notes.dat"
    path.write_text("time [s],force [N]\n0,1\n")
    with pytest.raises(DataError, match=r"notes\.dat: a \.dat file is read as an MTS 793 export"):
        load_measurement(path)


def test_cli_data_check_reads_the_export_and_prints_the_notes(dyno):
    path, *_ = dyno
    result = CliRunner().invoke(app, ["data", "check", str(path), "--require", "velocity"])
    assert result.exit_code == 0, result.output
    out = result.output
    assert f"{path}: {12 * 1024} samples, sample period 0.000976562 s" in out
    assert "  displacement [m]" in out and "  force [N]" in out
    assert "note: channels read as 'Running Time' [Sec] -> time" in out
    assert "note: time stamps deviate from a uniform base by up to" in out
    bad = CliRunner().invoke(app, ["data", "check", str(path), "--map", "Nope=force"])
    assert bad.exit_code == 2
    assert bad.output.strip().splitlines() == [
        f"error: {path}: channel map names 'Nope', which the file does not have; its channels are "
        "'Axial Displacement', 'Axial Force', 'Running Time'"
    ]


@pytest.mark.slow
def test_cli_train_accepts_the_export_and_prints_the_loader_notes(dyno, tmp_path):
    path, *_ = dyno
    out = tmp_path / "damper.onnx"
    result = CliRunner().invoke(
        app,
        [
            "train",
            str(path),
            "--preset",
            "damper-spline",
            "--out",
            str(out),
            "--max-epochs",
            "3",
            "--restarts",
            "1",
            "--hidden",
            "2",
        ],
    )
    assert result.exit_code == 0, result.output
    assert out.exists()
    assert "note: time stamps deviate from a uniform base" in result.output
    assert "note: channels read as 'Running Time' [Sec] -> time" in result.output
