"""The BRFD importer on the stored slice of the measured friction damper: SI units, attribution, joined runs, bad
files."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from nnfmu.data import DataError
from nnfmu.data.importers import load_brfd, load_brfd_series

SLICE = Path(__file__).parent / "brfd"
FILES = sorted(SLICE.glob("*.json.gz"))
RUNS = [SLICE / f"1Hz36lbtension{a}amplitude.json.gz" for a in ("0.5", "1", "1.5")]  # whole runs at 256 Hz
INCH = 0.0254  # m
KIP = 4448.2216152605  # N: 1000 lbf


def raw_rows(path: Path) -> np.ndarray:
    return np.asarray(json.load(gzip.open(path))["data"], dtype=float)


def write(path: Path, content: object) -> Path:
    path.write_bytes(gzip.compress(json.dumps(content).encode()))
    return path


def test_the_slice_is_small_and_attributed():
    assert len(FILES) == 4
    assert sum(p.stat().st_size for p in SLICE.iterdir()) < 300_000
    readme = (SLICE / "README.md").read_text(encoding="utf-8")
    assert "CC BY-SA 4.0" in readme and "0e09aa9d950760277e31c08cd93fd01f39a5af09" in readme
    assert 'Cite: Coble, Huggins, Cao, Ricles, Downey, "Dataset-Friction-Damper-with-Backlash", 2022.' in readme
    assert b"Attribution-ShareAlike 4.0 International" in (SLICE / "LICENSE.txt").read_bytes()


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_import_converts_to_si_and_keeps_the_licence(path):
    m = load_brfd(path)
    rows = raw_rows(path)
    assert m.names == ["displacement", "force", "velocity"]
    assert m.units == {"displacement": "m", "force": "N", "velocity": "m/s"}
    assert np.array_equal(m.time, rows[:, 0])
    assert np.allclose(m["displacement"], rows[:, 1] * INCH, rtol=1e-15, atol=0)
    assert np.allclose(m["force"], rows[:, 2] * KIP, rtol=1e-15, atol=0)
    assert np.allclose(m["velocity"], rows[:, 3] * INCH, rtol=1e-15, atol=0)
    assert m.sample_period == pytest.approx(json.load(gzip.open(path))["dt"])  # 1/1024 s, or 4/1024 s subsampled
    assert "CC BY-SA 4.0" in m.notes["licence"] and "Coble" in m.notes["licence"]
    assert m.source == str(path)


def test_the_measured_velocity_is_the_rate_of_the_measured_displacement():
    """An independent check of the units: in/s and in converted alike, so dx/dt matches v (to the rig's noise)."""
    m = load_brfd(SLICE / "1Hz36lbtension1amplitude.json.gz")
    rate = np.gradient(m["displacement"], m.sample_period)
    inner = slice(50, -50)
    scale = np.polyfit(m["velocity"][inner], rate[inner], 1)[0]
    assert scale == pytest.approx(1.0, abs=0.05)
    assert np.max(np.abs(m["displacement"])) == pytest.approx(1.0 * INCH, rel=0.05)  # the 1 in amplitude test


def test_runs_join_in_order_on_one_time_axis():
    runs = [load_brfd(path) for path in RUNS]
    m = load_brfd_series(RUNS)
    assert len(m) == sum(len(run) for run in runs) and m.units == runs[0].units
    np.testing.assert_array_equal(m.time, np.arange(len(m)) * runs[0].sample_period)
    np.testing.assert_array_equal(m["force"], np.concatenate([run["force"] for run in runs]))
    assert f"{RUNS[1].name}: rows {len(runs[0])}-{len(runs[0]) + len(runs[1]) - 1}" in m.notes["runs"]
    assert "CC BY-SA 4.0" in m.notes["licence"]


def test_runs_at_other_sample_rates_are_not_joined(tmp_path):
    rows = [[i / 1024, 0.0, 0.0, 0.0] for i in range(20)]
    other = write(tmp_path / "fast.json.gz", {"data": rows, "dt": 1 / 1024})
    with pytest.raises(DataError, match=r"fast\.json\.gz: sample period 0\.000976562 s differs"):
        load_brfd_series([RUNS[0], other])
    with pytest.raises(DataError, match="no BRFD files"):
        load_brfd_series([])


def test_missing_file(tmp_path):
    with pytest.raises(DataError, match="no such file"):
        load_brfd(tmp_path / "absent.json.gz")


def test_not_gzip(tmp_path):
    path = tmp_path / "plain.json.gz"
    path.write_text("{}")
    with pytest.raises(DataError, match=r"plain\.json\.gz: not a readable gzip file"):
        load_brfd(path)


def test_not_json(tmp_path):
    path = tmp_path / "text.json.gz"
    path.write_bytes(gzip.compress(b"t, x, F"))
    with pytest.raises(DataError, match="not JSON"):
        load_brfd(path)


def test_no_data_table(tmp_path):
    with pytest.raises(DataError, match="'data' table"):
        load_brfd(write(tmp_path / "empty.json.gz", {"dt": 0.001}))


def test_too_few_columns(tmp_path):
    with pytest.raises(DataError, match=r"shape \(20, 3\).*at least 4 columns"):
        load_brfd(write(tmp_path / "narrow.json.gz", {"data": [[i / 1024, 0.0, 0.0] for i in range(20)]}))


def test_unknown_unit_is_named(tmp_path):
    rows = [[i / 1024, 0.0, 0.0, 0.0] for i in range(20)]
    with pytest.raises(DataError, match="channel 'force'.*'furlong'"):
        load_brfd(write(tmp_path / "unit.json.gz", {"data": rows, "friction force units": "furlong"}))


def test_time_axis_disagreeing_with_dt(tmp_path):
    rows = [[i / 1000, 0.0, 0.0, 0.0] for i in range(20)]
    with pytest.raises(DataError, match="'dt' says"):
        load_brfd(write(tmp_path / "dt.json.gz", {"data": rows, "dt": 1 / 1024}))


def test_non_finite_value_is_named(tmp_path):
    rows = [[i / 1024, 0.0, 0.0, 0.0] for i in range(20)]
    rows[7][2] = None
    with pytest.raises(DataError, match="force"):
        load_brfd(write(tmp_path / "nan.json.gz", {"data": rows}))
