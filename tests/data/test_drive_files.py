"""Drive files on disk: CSV, MDF 4 and RPC III round trips, units, atomic writes and errors naming the file."""

import os
import re

import numpy as np
import pytest
from rpc3 import rpc3 as rpc3_file

from nnfmu.data import DataError, Measurement
from nnfmu.data.drive_files import read_drive, write_drive
from nnfmu.vehicle.drive import CHANNELS, DriveSettings, Pothole, generate_drive

INT16_FULL_SCALE = 32752  # counts of max|x| in rpc3-file's SHORT_INTEGER scaling
FLOAT32_EPS = 2.0**-24  # relative rounding of a float32


@pytest.fixture(scope="module")
def drive():
    return generate_drive(DriveSettings(duration=4.0, events=(Pothole(time=1.0),)))


def _files_in(folder):
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize("suffix", [".csv", ".mf4"])
def test_csv_and_mdf_round_trips_are_exact(tmp_path, drive, suffix):
    back = read_drive(write_drive(drive, tmp_path / f"drive{suffix}"))
    assert list(back.channels) == list(CHANNELS)  # only the stored channels: no derived velocities
    assert back.units == {name: "m" for name in CHANNELS}
    np.testing.assert_array_equal(back.time, drive.time)
    for name in CHANNELS:
        np.testing.assert_array_equal(back[name], drive[name])


@pytest.mark.parametrize("suffix", [".rsp", ".drv", ".tim"])
def test_rpc_int16_round_trip_is_within_half_a_count(tmp_path, drive, suffix):
    back = read_drive(write_drive(drive, tmp_path / f"drive{suffix}"))
    assert list(back.channels) == list(CHANNELS)
    assert back.units == {name: "m" for name in CHANNELS}
    np.testing.assert_allclose(back.time, drive.time, rtol=0, atol=1e-12)
    for name in CHANNELS:
        peak = np.max(np.abs(drive[name]))
        error = np.max(np.abs(back[name] - drive[name]))
        # Half a count of max|x| / 32752, plus the float32 the library returns.
        assert error <= peak * (0.5 / INT16_FULL_SCALE + FLOAT32_EPS)
        assert error > peak * 0.1 / INT16_FULL_SCALE  # it really was quantised to 16 bits


def test_rpc_float32_round_trip_is_within_float32_rounding(tmp_path, drive):
    back = read_drive(write_drive(drive, tmp_path / "drive.rsp", rpc_data_type="float32"))
    for name in CHANNELS:
        np.testing.assert_allclose(back[name], drive[name], rtol=FLOAT32_EPS, atol=0)
        assert not np.array_equal(back[name], drive[name])


@pytest.mark.parametrize(("data_type", "stored"), [("int16", "SHORT_INTEGER"), ("float32", "FLOATING_POINT")])
def test_rpc_header_says_what_the_file_holds(tmp_path, drive, data_type, stored):
    path = write_drive(drive, tmp_path / "drive.drv", rpc_data_type=data_type)
    channels, params = rpc3_file.read(str(path))
    assert params["DATA_TYPE"] == stored
    assert params["DELTA_T"] == pytest.approx(0.001, rel=1e-15)
    assert params["TIME_TYPE"] == "DRIVE"
    assert [(c.name, c.unit) for c in channels] == [(name, "m") for name in CHANNELS]


def test_rpc_time_step_without_a_decimal_point_reads_back(tmp_path):
    # 1e-05 s is written by Python without a '.', which rpc3-file would not read as a number.
    m = Measurement(
        time=np.arange(32) * 1e-5,
        channels={"stroke_displacement": np.linspace(0, 1, 32)},
        units={"stroke_displacement": "m"},
    )
    back = read_drive(write_drive(m, tmp_path / "fast.rsp", rpc_data_type="float32"))
    assert back.sample_period == pytest.approx(1e-5, rel=1e-12)


def test_rpc_file_in_millimetres_is_read_in_metres(tmp_path):
    values = np.sin(np.linspace(0.0, 6.0, 100)) * 25.0  # mm
    channel = rpc3_file.Channel(name="FL post", unit="mm", dt=0.002, data=values)
    rpc3_file.write(str(tmp_path / "lab.rsp"), [channel], datatype=float)
    back = read_drive(tmp_path / "lab.rsp")
    assert back.units == {"FL post": "m"}
    assert back.sample_period == pytest.approx(0.002)
    np.testing.assert_allclose(back["FL post"], values * 1e-3, rtol=FLOAT32_EPS)


def test_rpc_file_with_an_unknown_unit_names_file_and_channel(tmp_path):
    """A displacement in an unknown unit is refused; a channel whose name and unit nnfmu both do not know is kept."""
    channel = rpc3_file.Channel(name="post_displacement", unit="furlong", dt=0.001, data=np.zeros(50))
    rpc3_file.write(str(tmp_path / "odd.rsp"), [channel], datatype=float)
    with pytest.raises(DataError, match=r"odd\.rsp.*'post_displacement'.*'furlong'"):
        read_drive(tmp_path / "odd.rsp")
    channel = rpc3_file.Channel(name="post", unit="furlong", dt=0.001, data=np.zeros(50))
    rpc3_file.write(str(tmp_path / "kept.rsp"), [channel], datatype=float)
    assert read_drive(tmp_path / "kept.rsp").units["post"] == "furlong"


@pytest.mark.parametrize("name", ["garbage.rsp", "garbage.tim", "garbage.csv", "garbage.mf4"])
def test_unreadable_file_raises_an_error_naming_it(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"\x00\x01 this is not a drive file \xff" * 20)
    with pytest.raises(DataError, match=name.replace(".", r"\.")):
        read_drive(path)


def test_missing_file_and_unknown_type_raise_errors_naming_them(tmp_path, drive):
    with pytest.raises(DataError, match=r"absent\.drv: no such file"):
        read_drive(tmp_path / "absent.drv")
    with pytest.raises(DataError, match=r"drive\.xyz.*'\.xyz'"):
        read_drive(tmp_path / "drive.xyz")
    with pytest.raises(DataError, match=r"drive\.xyz.*'\.xyz'"):
        write_drive(drive, tmp_path / "drive.xyz")


def test_a_failed_rpc_write_leaves_no_file(tmp_path, drive):
    bad = Measurement(
        time=drive.time,
        channels={"x" * 97 + "_displacement": drive[CHANNELS[0]]},
        units={"x" * 97 + "_displacement": "m"},
    )
    with pytest.raises(DataError, match="at most 96 characters"):
        write_drive(bad, tmp_path / "drive.rsp")
    late = Measurement(time=drive.time + 1.0, channels=dict(drive.channels), units=dict(drive.units))
    with pytest.raises(DataError, match=r"starts at t = 1 s"):
        write_drive(late, tmp_path / "drive.rsp")
    with pytest.raises(DataError, match=r"'int8'"):
        write_drive(drive, tmp_path / "drive.rsp", rpc_data_type="int8")
    assert _files_in(tmp_path) == []


def test_rewriting_a_drive_file_replaces_it_whole(tmp_path, drive):
    path = tmp_path / "drive.tim"
    write_drive(drive, path)
    shorter = drive.slice(0, 1000)
    write_drive(shorter, path, rpc_data_type="float32")
    assert len(read_drive(path)) == 1000
    assert _files_in(tmp_path) == ["drive.tim"]


def with_header_field(source, target, key: str, value: bytes):
    """A copy of the RPC III file `source` at `target` with header field `key` set to `value`."""
    data = bytearray(source.read_bytes())
    at = next(i for i in range(0, len(data), 128) if data[i : i + 32].rstrip(b"\0 ") == key.encode())
    data[at + 32 : at + 128] = value.ljust(96, b"\0")
    target.write_bytes(bytes(data))
    return target


@pytest.mark.parametrize(
    "key, value, words",
    [
        ("DELTA_T", b"1.0e300", "DELTA_T = '1.0e300' s is not a sample period in [1e-09, 10000] s"),
        ("DELTA_T", b"1.0e-300", "DELTA_T = '1.0e-300' s is not a sample period"),
        ("DELTA_T", b"1e300", "DELTA_T = '1e300' is not a finite number with a decimal point"),
        ("DELTA_T", b"nan", "DELTA_T = 'nan' is not a finite number"),
        ("CHANNELS", b"x4", "CHANNELS = 'x4' is not a whole number"),
        ("CHANNELS", b"999999999", "CHANNELS = 999999999 is outside [1, 4096]"),
        ("NUM_PARAMS", b"-3", "NUM_PARAMS = -3 is outside"),
        ("DATA_TYPE", b"COMPLEX", "DATA_TYPE = 'COMPLEX' is not one of"),
        ("SCALE.CHAN_2", b"big", "SCALE.CHAN_2 = 'big' is not a finite number"),
        ("FRAMES", b"1.5", "FRAMES = '1.5' is not a whole number"),
        ("DESC.CHAN_1", b"", "DESC.CHAN_1 is empty"),  # was read as a channel named '', refused later unclearly
    ],
)
def test_a_bad_rpc_header_field_is_named_with_the_file(tmp_path, drive, key, value, words):
    """These were tracebacks (DELTA_T 1e300: OverflowError, 1e-300: ZeroDivisionError, in cosim) or the rpc3
    package's messages naming no field ("'<' not supported between instances of 'str' and 'int'")."""
    good = write_drive(drive, tmp_path / "good.rsp")
    bad = with_header_field(good, tmp_path / "bad.rsp", key, value)
    with pytest.raises(DataError) as caught:
        read_drive(bad)
    assert str(bad) in str(caught.value) and words in str(caught.value), str(caught.value)


@pytest.mark.parametrize("name", ["drive.rsp", "drive.csv"])
@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_a_drive_that_is_a_fifo_or_a_device_is_refused_as_such(tmp_path, kind, name):
    """A FIFO or a link to /dev/zero was refused as 'no such file' (it exists): now named for what it is."""
    path = tmp_path / name
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")
    with pytest.raises(
        DataError, match=rf"{re.escape(name)}: is a {'FIFO' if kind == 'fifo' else 'device'}, not a regular"
    ):
        read_drive(path)
