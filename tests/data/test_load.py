"""Loading CSV/MDF rig files: conversion to SI, exact round trips, and an error naming the file for each fault."""

import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from asammdf import MDF, Signal

from nnfmu.data import DataError, Measurement, check_measurement, load_measurement, save_measurement
from nnfmu.data import save as save_module
from nnfmu.data.csv_io import read_csv

RATE = 1000.0
N = 64


def _write_csv(path, header, rows):
    path.write_text(header + "\n" + "".join(",".join(str(v) for v in row) + "\n" for row in rows), encoding="utf-8")
    return path


def _rows(n=N, columns=2):
    t = np.arange(n) / RATE
    return [[t[i], *(np.sin(2 * np.pi * 5 * t[i] + c) for c in range(columns))] for i in range(n)]


def _measurement(n=N):
    rng = np.random.default_rng(7)
    t = np.arange(n) / RATE
    return Measurement(
        time=t,
        channels={
            "displacement": rng.normal(0.0, 0.01, n),
            "velocity": rng.normal(0.0, 0.3, n) * 10.0 ** rng.integers(-12, 12, n),
            "force": rng.normal(0.0, 1e3, n),
            "temperature": 293.15 + rng.random(n),
        },
        units={"displacement": "m", "velocity": "m/s", "force": "N", "temperature": "K"},
        source="test",
    )


def test_csv_in_inches_and_pounds_is_converted_to_si(tmp_path):
    rows = [[i / RATE, 0.5 * i, 2.0 * i] for i in range(N)]
    path = _write_csv(tmp_path / "imperial.csv", "time [s],displacement [in],force [lbf]", rows)
    m = load_measurement(path)
    np.testing.assert_allclose(m["displacement"], 0.5 * 0.0254 * np.arange(N), rtol=1e-13)
    np.testing.assert_allclose(m["force"], 2.0 * 0.45359237 * 9.80665 * np.arange(N), rtol=1e-13)
    assert m.units["displacement"] == "m" and m.units["force"] == "N"
    np.testing.assert_allclose(m["velocity"], 0.5 * 0.0254 * RATE, rtol=1e-9)  # derived, in m/s
    assert m.units["velocity"] == "m/s"
    assert m.source == str(path)


def test_header_spellings_and_millisecond_time(tmp_path):
    rows = [[float(i), 1.0, 2.0] for i in range(N)]
    path = _write_csv(tmp_path / "loose.csv", " time[ms] ,  axial_displacement (mm),axial_force [ kN ]", rows)
    m = load_measurement(path)
    np.testing.assert_allclose(m.time, np.arange(N) * 1e-3)
    assert m.names == ["axial_displacement", "axial_force", "axial_velocity", "axial_acceleration"]
    np.testing.assert_allclose(m["axial_force"], 2000.0)


def test_excel_csv_with_byte_order_mark_and_crlf(tmp_path):
    path = tmp_path / "excel.csv"
    text = "time [s],torque [N-m]\r\n" + "".join(f"{i / RATE},{i}\r\n" for i in range(N))
    path.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    m = load_measurement(path)
    assert m.names == ["torque"]
    np.testing.assert_array_equal(m["torque"], np.arange(N))


def test_semicolon_delimited_csv(tmp_path):
    path = tmp_path / "semi.csv"
    path.write_text("time [s];force [N]\n" + "".join(f"{i / RATE};{i}\n" for i in range(N)), encoding="utf-8")
    np.testing.assert_array_equal(load_measurement(path)["force"], np.arange(N))


def test_csv_round_trip_is_exact(tmp_path):
    m = _measurement()
    path = save_measurement(m, tmp_path / "out" / "rig.csv")
    assert path.read_text().splitlines()[0] == "time [s],displacement [m],velocity [m/s],force [N],temperature [K]"
    back = load_measurement(path)
    assert np.array_equal(back.time, m.time)
    for name in m.channels:
        assert np.array_equal(back[name], m[name]), name
        assert back.units[name] == m.units[name]
    assert set(back.channels) == set(m.channels) | {"acceleration"}  # acceleration derived from velocity


def test_mdf4_round_trip_keeps_values_and_units(tmp_path):
    m = _measurement()
    path = save_measurement(m, tmp_path / "rig.mf4")
    with MDF(str(path)) as mdf:
        assert mdf.get("force").unit == "N"
        assert mdf.get("velocity").unit == "m/s"
    back = load_measurement(path)
    assert np.array_equal(back.time, m.time)
    for name in m.channels:
        assert np.array_equal(back[name], m[name]), name
        assert back.units[name] == m.units[name]


def _write_mdf(path, groups):
    mdf = MDF(version="4.10")
    for time, signals in groups:
        mdf.append([Signal(values, time, name=name, unit=unit) for name, unit, values in signals])
    mdf.save(str(path), overwrite=True)
    mdf.close()
    return path


def test_mdf_channel_units_are_converted_and_equal_groups_merge(tmp_path):
    t = np.arange(N) / RATE
    path = _write_mdf(
        tmp_path / "rig.mf4",
        [(t, [("conical_rotation", "deg", np.full(N, 90.0))]), (t.copy(), [("conical_torque", "kN.m", np.ones(N))])],
    )
    m = load_measurement(path, required=("conical_angular_velocity",))
    np.testing.assert_allclose(m["conical_rotation"], np.pi / 2)
    np.testing.assert_allclose(m["conical_torque"], 1000.0)
    assert m.units == {"conical_rotation": "rad", "conical_torque": "N.m", "conical_angular_velocity": "rad/s"}


def test_mdf_with_two_time_bases_is_refused(tmp_path):
    t = np.arange(N) / RATE
    path = _write_mdf(
        tmp_path / "mixed.mf4",
        [(t, [("displacement", "m", np.zeros(N))]), (t[::2], [("force", "N", np.zeros(N // 2))])],
    )
    with pytest.raises(DataError, match=r"mixed\.mf4: channel 'force' \(group 1, 32 samples\) has another time base"):
        load_measurement(path)


def test_mdf_invalid_file_is_named(tmp_path):
    path = tmp_path / "broken.mf4"
    path.write_bytes(b"not an mdf file at all")
    with pytest.raises(DataError, match=r"broken\.mf4: not a readable MDF file"):
        load_measurement(path)


@pytest.mark.parametrize(
    ("header", "message"),
    [
        ("time [s],displacement [m],force", r"header column 3 'force' has no unit"),
        ("time [s],displacement [],force [N]", r"header column 2 'displacement \[\]' has an empty unit"),
        ("time [s]", r"no channels besides time"),
        ("time [s],[m],force [N]", r"header column 2 '\[m\]' has no channel name"),
        ("t [s],displacement [m],force [N]", r"the first column must be 'time \[s\]', found 't \[s\]'"),
        ("time [s],force [N],force [N]", r"column\(s\) 'force' appear more than once"),
        ("time [s],displacement [m],force [lbs]", r"channel 'force': unknown force unit 'lbs'; force units are N, kN"),
        ("time [s],displacement [m],force [m]", r"channel 'force' is a force but its unit 'm' is a length"),
        ("time [m],displacement [m],force [N]", r"channel 'time' is a time but its unit 'm' is a length"),
        ("time [s],displacement [m],gizmo [#]", r"channel 'gizmo': '#' is not a unit .*; known units are"),
    ],
)
def test_bad_header_names_file_and_column(tmp_path, header, message):
    path = _write_csv(tmp_path / "bad.csv", header, _rows())
    with pytest.raises(DataError, match=r"bad\.csv: " + message):
        load_measurement(path)


def test_missing_required_channel_lists_what_exists(tmp_path):
    path = _write_csv(tmp_path / "rig.csv", "time [s],displacement [m],force [N]", _rows())
    with pytest.raises(
        DataError,
        match=r"rig\.csv: missing required channel\(s\) 'temperature'; "
        r"it has: displacement, force, velocity, acceleration",
    ):
        load_measurement(path, required=("force", "velocity", "temperature"))


def test_time_that_does_not_increase_names_the_sample(tmp_path):
    rows = _rows()
    rows[10][0] = rows[9][0]
    path = _write_csv(tmp_path / "stuck.csv", "time [s],displacement [m],force [N]", rows)
    with pytest.raises(DataError, match=r"stuck\.csv: time does not increase at sample 10: t = 0\.009 s then 0\.009 s"):
        load_measurement(path)


def test_non_uniform_time_names_the_sample(tmp_path):
    rows = _rows()
    rows[20][0] += 0.2 / RATE  # a fifth of the period, four times the clock-scatter tolerance
    path = _write_csv(tmp_path / "jitter.csv", "time [s],displacement [m],force [N]", rows)
    with pytest.raises(DataError, match=r"jitter\.csv: time is not uniformly sampled at sample 20 \(t = 0\.0202 s\)"):
        load_measurement(path)


def test_a_stamp_scattering_within_the_clock_bound_gets_the_fitted_base_and_a_note(tmp_path):
    rows = _rows()
    rows[20][0] += 0.01 / RATE  # 1 % of the period: more than sampling jitter, well within a clock's 5 %
    m = load_measurement(_write_csv(tmp_path / "scatter.csv", "time [s],displacement [m],force [N]", rows))
    np.testing.assert_allclose(m.time, np.arange(N) / RATE, rtol=0, atol=1e-3 / RATE)
    assert "within the 0.05 of the period nnfmu accepts as a clock's scatter" in m.notes["time"]


def test_jitter_within_tolerance_is_accepted(tmp_path):
    rows = _rows()
    rows[20][0] += 0.0002 / RATE  # 0.02 % of the period
    path = _write_csv(tmp_path / "fine.csv", "time [s],displacement [m],force [N]", rows)
    assert len(load_measurement(path)) == N


def test_nan_names_channel_sample_and_time(tmp_path):
    rows = _rows()
    rows[5][2] = float("nan")
    rows[7][2] = float("inf")
    path = _write_csv(tmp_path / "nan.csv", "time [s],displacement [m],force [N]", rows)
    with pytest.raises(
        DataError,
        match=r"nan\.csv: channel 'force' has 2 non-finite value\(s\), the first nan at sample 5 \(t = 0\.005 s\)",
    ):
        load_measurement(path)


def test_text_in_a_number_cell_names_line_and_column(tmp_path):
    rows = _rows()
    rows[3][1] = "oops"
    path = _write_csv(tmp_path / "text.csv", "time [s],displacement [m],force [N]", rows)
    with pytest.raises(DataError, match=r"text\.csv: line 5, column 'displacement \[m\]': 'oops' is not a number"):
        load_measurement(path)


def test_short_row_names_the_line(tmp_path):
    rows = _rows()
    rows[6] = rows[6][:2]
    path = _write_csv(tmp_path / "short.csv", "time [s],displacement [m],force [N]", rows)
    with pytest.raises(DataError, match=r"short\.csv: line 8 has 2 cells, the header 3"):
        load_measurement(path)


def test_too_few_samples(tmp_path):
    path = _write_csv(tmp_path / "tiny.csv", "time [s],displacement [m],force [N]", _rows(n=10))
    with pytest.raises(DataError, match=r"tiny\.csv: 10 samples, at least 16 needed"):
        load_measurement(path)


def test_header_only_file_has_no_samples(tmp_path):
    path = _write_csv(tmp_path / "empty.csv", "time [s],force [N]", [])
    with pytest.raises(DataError, match=r"empty\.csv: 0 samples, at least 16 needed"):
        load_measurement(path)


def test_implausibly_low_temperature_is_refused(tmp_path):
    rows = [[i / RATE, 20.0] for i in range(N)]
    path = _write_csv(tmp_path / "celsius.csv", "time [s],damper_temperature [K]", rows)
    with pytest.raises(
        DataError,
        match=r"celsius\.csv: channel 'damper_temperature' reaches 20 K at sample 0 \(t = 0 s\), "
        r"below the plausible 150 K",
    ):
        load_measurement(path)


def test_unknown_suffix_and_missing_file(tmp_path):
    with pytest.raises(DataError, match=r"rig\.xlsx: unknown file type '\.xlsx'; nnfmu reads \.csv, \.mf4, \.mdf"):
        load_measurement(tmp_path / "rig.xlsx")
    with pytest.raises(DataError, match=r"absent\.csv: no such file"):
        load_measurement(tmp_path / "absent.csv")


def test_save_refuses_invalid_measurement_without_writing(tmp_path):
    m = _measurement()
    m.channels["force"][3] = np.nan
    with pytest.raises(DataError, match=r"test: channel 'force' has 1 non-finite"):
        save_measurement(m, tmp_path / "rig.csv")
    m = _measurement()
    m.units["force"] = "kN"
    with pytest.raises(DataError, match=r"channel 'force' is a force in 'kN'; it must be in 'N'"):
        save_measurement(m, tmp_path / "rig.mf4")
    assert list(tmp_path.iterdir()) == []


def test_save_into_a_path_under_a_file_fails_and_writes_nothing(tmp_path):
    blocker = tmp_path / "blocker"
    blocker.write_text("a file, not a directory")
    with pytest.raises(OSError):
        save_measurement(_measurement(), blocker / "rig.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]
    assert blocker.read_text() == "a file, not a directory"


@pytest.mark.parametrize("suffix", [".csv", ".mf4"])
def test_failure_mid_write_keeps_the_old_file_and_leaves_no_temp(tmp_path, monkeypatch, suffix):
    target = save_measurement(_measurement(), tmp_path / f"rig{suffix}")
    before = target.read_bytes()

    def fail_half_way(m, path):
        path.write_bytes(before[: len(before) // 2])
        raise RuntimeError("disk full")

    monkeypatch.setitem(save_module.WRITERS, suffix, fail_half_way)
    with pytest.raises(RuntimeError, match="disk full"):
        save_measurement(_measurement(n=N + 10), target)
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [target.name]


def test_check_names_the_given_source_and_missing_unit():
    m = _measurement()
    del m.units["force"]
    with pytest.raises(DataError, match=r"^damper rig simulator: channel 'force' has no unit$"):
        check_measurement(m, source="damper rig simulator")
    check_measurement(_measurement(), required=("force", "temperature"))


def test_mass_in_grams_is_a_mass_not_an_acceleration(tmp_path):
    rows = [[i / RATE, 500.0, 1.0] for i in range(N)]
    m = load_measurement(_write_csv(tmp_path / "mass.csv", "time [s],mass [g],body_acceleration [g]", rows))
    np.testing.assert_allclose(m["mass"], 0.5, rtol=1e-15)
    assert m.units["mass"] == "kg"
    np.testing.assert_allclose(m["body_acceleration"], 9.80665, rtol=1e-15)
    with pytest.raises(DataError, match=r"channel 'payload': unit 'g' is an acceleration or a mass, and the name"):
        load_measurement(_write_csv(tmp_path / "which.csv", "time [s],payload [g]", [r[:2] for r in rows]))


def test_same_channel_in_two_spellings_is_refused_naming_both_columns(tmp_path):
    path = _write_csv(tmp_path / "twice.csv", "time [s],force [N],Force [kN]", _rows())
    with pytest.raises(
        DataError,
        match=r"twice\.csv: column\(s\) 'force' appear more than once: column 2 'force \[N\]' and column 3 "
        r"'Force \[kN\]' name the same channel",
    ):
        load_measurement(path)


def test_megabyte_header_cell_is_refused_before_the_file_is_read(tmp_path):
    path = _write_csv(tmp_path / "huge.csv", "time [s]," + "x" * 1_000_000 + " [N]", _rows(columns=1))
    with pytest.raises(DataError, match=r"huge\.csv: the header line is longer than 65536 characters"):
        load_measurement(path)


def test_channel_map_renames_csv_channels(tmp_path):
    path = _write_csv(tmp_path / "lab.csv", "time [s],stroke [mm],load [kN]", _rows())
    m = load_measurement(path, required=("force", "velocity"), channel_map={"Stroke": "displacement", "load": "force"})
    assert m.names[:2] == ["displacement", "force"]
    assert m.notes["channels"] == "channels renamed by the channel map: 'stroke' -> displacement, 'load' -> force"
    with pytest.raises(DataError, match=r"lab\.csv: after the channel map, 'stroke' and 'load' would both be"):
        load_measurement(path, channel_map={"load": "stroke"})


def test_mdf_channels_differing_only_in_case_are_refused(tmp_path):
    t = np.arange(N) / RATE
    path = _write_mdf(tmp_path / "case.mf4", [(t, [("force", "N", np.zeros(N))]), (t, [("Force", "kN", np.ones(N))])])
    with pytest.raises(DataError, match=r"case\.mf4: channel 'force' \(group 0\) and channel 'Force' \(group 1\) name"):
        load_measurement(path)


def _corrupt_channel_offset(path):
    """Overwrite the byte offset of channel 'force' in its MDF 4 CN block (asammdf's reader trusts it)."""
    with MDF(str(path)) as mdf:
        force = next(c for c in mdf.groups[0].channels if c.name == "force")
        address, offset = force.address, force.byte_offset
    data = bytearray(path.read_bytes())
    links = int.from_bytes(data[address + 16 : address + 24], "little")
    field = address + 24 + 8 * links + 4  # cn_type, sync_type, data_type, bit_offset, then the uint32 byte offset
    assert int.from_bytes(data[field : field + 4], "little") == offset
    data[field : field + 4] = (1_577_058_312).to_bytes(4, "little")
    path.write_bytes(bytes(data))


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["truncated", "channel offset"])
def test_corrupt_mdf_gives_only_the_error_line_on_the_command_line(tmp_path, damage):
    path = save_measurement(_measurement(), tmp_path / "rig.mf4")
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[:200])
    else:
        _corrupt_channel_offset(path)
    result = subprocess.run(
        [sys.executable, "-c", "from nnfmu.cli import app; app()", "data", "check", str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 2, result.stderr  # a crash in asammdf's compiled reader ends with -11 (SIGSEGV)
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {path}: not a readable MDF file: "), result.stderr


def test_an_mr_damper_record_with_a_command_voltage_loads_in_si(tmp_path):
    """Shaped like a public MR-damper record: 3 kHz, stroke in cm, force in N, the coil's command in V (tab-separated);
    the command channel no longer blocks the ones nnfmu needs."""
    path = tmp_path / "mr_damper.csv"
    rows = [
        f"{k / 3000:.8g}\t{0.5 * np.sin(k / 50):.6f}\t{10 * np.cos(k / 50):.6f}\t{120 * np.sin(k / 40):.3f}\t"
        f"{2.5 if k > 60 else 0.0:.2f}"
        for k in range(120)
    ]
    path.write_text("time [s]\tdisplacement [cm]\tvelocity [cm/s]\tforce [N]\tvoltage [V]\n" + "\n".join(rows) + "\n")
    m = load_measurement(path)
    assert (m.units["displacement"], m.units["velocity"], m.units["voltage"]) == ("m", "m/s", "V")
    np.testing.assert_allclose(
        m["displacement"][:3], [0.0, 0.005 * np.sin(1 / 50), 0.005 * np.sin(2 / 50)], rtol=0, atol=1e-8
    )  # printed to 1e-6 cm
    assert m["voltage"][0] == 0.0 and m["voltage"][-1] == 2.5


def test_a_channel_nnfmu_cannot_convert_keeps_its_unit_and_blocks_nothing(tmp_path):
    rows = [[i / RATE, 1e-3 * i, 2.0 * i, 4.7] for i in range(N)]
    path = _write_csv(tmp_path / "coil.csv", "time [s],displacement [mm],force [kN],coil [ohm]", rows)
    m = load_measurement(path, required=("displacement", "force"))
    assert (m.units["displacement"], m.units["force"], m.units["coil"]) == ("m", "N", "ohm")
    assert m.notes["units"] == "kept as declared (quantities nnfmu does not convert): coil [ohm]"
    np.testing.assert_array_equal(m["coil"], 4.7)
    again = load_measurement(save_measurement(m, tmp_path / "again.csv"))
    assert again.units["coil"] == "ohm"


@pytest.mark.slow
def test_reading_a_csv_takes_about_twice_its_columns_in_memory(tmp_path: Path) -> None:
    """The text is parsed a chunk at a time into float64 columns: 400 000 rows of 4 columns (12.8 MB as float64)
    peak below 3 times that (the whole text and a Python string per line took 11 times; 4.2 GB for 10 M rows)."""
    rows = 400_000
    t = np.arange(rows) * 1e-3
    path = tmp_path / "big.csv"
    with path.open("w", encoding="utf-8") as stream:
        stream.write("time [s],displacement [m],velocity [m/s],force [N]\n")
        np.savetxt(stream, np.column_stack([t, np.sin(t), np.cos(t), 100 * np.sin(3 * t)]), fmt="%.6g", delimiter=",")
    tracemalloc.start()
    try:
        raw = read_csv(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    columns = 4 * rows * 8
    assert len(raw.time) == rows and raw.channels["force"][-1] == pytest.approx(100 * np.sin(3 * t[-1]), rel=1e-5)
    assert peak < 3 * columns, f"peak {peak / 1e6:.1f} MB for {columns / 1e6:.1f} MB of columns"
