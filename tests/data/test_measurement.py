"""The measurement owns its time axis: it is checked when made, and its start and sample period are stored."""

import dataclasses

import numpy as np
import pytest

from nnfmu.component import same_period
from nnfmu.data import DataError, Measurement, load_measurement

RATE = 1024.0
N = 256


def _channels(n: int = N) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    return {"force": np.sin(np.arange(n) / 10.0)}, {"force": "N"}


def test_construction_from_start_and_period_stores_them_and_derives_the_stamps() -> None:
    channels, units = _channels()
    m = Measurement.uniform(2.5, 1.0 / RATE, channels, units, source="rig")
    assert m.start == 2.5
    assert same_period(m.sample_period, 1.0 / RATE)
    assert len(m) == N and m.source == "rig"
    np.testing.assert_array_equal(m.time, 2.5 + np.arange(N) / RATE)


@pytest.mark.parametrize(("start", "period"), [(0.0, 0.0), (0.0, -1e-3), (0.0, float("nan")), (float("inf"), 1e-3)])
def test_construction_from_a_bad_start_or_period_is_refused_naming_the_source(start: float, period: float) -> None:
    channels, units = _channels()
    with pytest.raises(DataError, match=r"^drive\.rsp: a time axis needs a finite start and period > 0"):
        Measurement.uniform(start, period, channels, units, source="drive.rsp")


def test_a_uniform_time_array_is_kept_and_its_start_and_period_stored() -> None:
    time = 0.75 + np.arange(N) / RATE
    channels, units = _channels()
    m = Measurement(time, channels, units, "sim")
    assert m.time is time  # a float64 array is kept as it is: no stamp changes
    assert m.start == 0.75
    assert m.sample_period == (time[-1] - time[0]) / (N - 1)
    assert abs(m.sample_period - 1.0 / RATE) <= 1e-15


def test_a_non_uniform_time_array_is_refused_naming_the_source_and_sample() -> None:
    time = np.arange(N) / RATE
    time[100:] += 0.2 / RATE  # a fifth of the period from sample 100 on: four times the clock-scatter tolerance
    channels, units = _channels()
    with pytest.raises(DataError, match=r"^bench rig: time is not uniformly sampled at sample 100 \(t = 0\.0978"):
        Measurement(time, channels, units, "bench rig")


def test_stamps_scattering_beyond_the_jitter_get_their_fitted_base_and_a_note() -> None:
    """What a loader accepts the measurement accepts too: float32 stamps of a 1024 Hz clock jump by a few us where
    they pass 64 s (its rounding differs on each side); the axis becomes their least-squares base, uniform again."""
    time = (63.9173 + np.arange(N) / RATE).astype(np.float32).astype(float)
    channels, units = _channels()
    m = Measurement(time, channels, units, "f32 clock", notes={"format": "kept"})
    assert np.max(np.abs(m.time - time)) > 1e-3 / RATE  # the stamps scatter beyond the jitter ...
    assert np.max(np.abs(np.diff(m.time) - m.sample_period)) < 1e-9 / RATE  # ... the axis does not
    assert "clock's scatter" in m.notes["time"] and m.notes["format"] == "kept"


@pytest.mark.parametrize(
    ("time", "message"),
    [
        (np.array([0.0, 1e-3, 1e-3, 3e-3]), r"^rig: time does not increase at sample 2"),
        (np.array([0.0, 1e-3, np.nan, 3e-3]), r"^rig: time is nan at sample 2$"),
        (np.array([0.0]), r"^rig: 1 sample\(s\); a measurement needs at least 2"),
        (np.zeros((2, 2)), r"^rig: time must have shape \(n,\), has shape \(2, 2\)"),
    ],
)
def test_a_time_axis_that_is_no_axis_is_refused(time: np.ndarray, message: str) -> None:
    with pytest.raises(DataError, match=message):
        Measurement(time, {"force": np.zeros(len(time))}, {"force": "N"}, "rig")


def test_eight_significant_digit_stamps_are_accepted() -> None:
    time = 37.0 + np.arange(4096) / RATE  # stamps from 37 s: a last printed digit of 1e-6 s, 0.1 % of the period
    printed = np.array([float(f"{t:.8g}") for t in time])
    assert np.max(np.abs(printed - time)) > 1e-7  # the rounding is really there
    m = Measurement(printed, {"force": np.zeros(time.size)}, {"force": "N"}, "lab.csv")
    assert m.start == 37.0
    assert same_period(m.sample_period, 1.0 / RATE)


def test_a_slice_keeps_the_start_and_the_period() -> None:
    channels, units = _channels()
    m = Measurement.uniform(1.0, 1.0 / RATE, channels, units, source="rig")
    part = m.slice(10, 110)
    assert part.start == m.time[10] and len(part) == 100
    assert abs(part.sample_period - m.sample_period) <= 1e-12 * m.sample_period
    np.testing.assert_array_equal(part["force"], m["force"][10:110])
    with pytest.raises(DataError, match=r"rig\[5:6\]: 1 sample\(s\)"):
        m.slice(5, 6)


def test_the_axis_and_its_start_and_period_cannot_drift_apart() -> None:
    channels, units = _channels()
    m = Measurement.uniform(0.0, 1.0 / RATE, channels, units)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.time = m.time * 2.0  # type: ignore[misc]
    later = dataclasses.replace(m, time=m.time + 4.0)  # a new measurement is checked and measured anew
    assert later.start == 4.0 and later.sample_period == m.sample_period


def test_loaded_stamps_rounded_beyond_the_jitter_get_their_fitted_base(tmp_path) -> None:
    """Stamps printed to 4 decimals at 1024 Hz stray by up to 5 % of a period: the loader, which knows their printed
    resolution, replaces them by their least-squares base before the measurement checks it."""
    rows = [f"{k / RATE:.4f},{np.sin(k / 10.0)}" for k in range(N)]
    path = tmp_path / "coarse.csv"
    path.write_text("time [s],force [N]\n" + "\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(DataError, match=r"^coarse\.csv-stamps: time is not uniformly sampled"):
        Measurement(np.array([float(r.split(",")[0]) for r in rows]), *_channels(), "coarse.csv-stamps")
    m = load_measurement(path)
    assert abs(m.sample_period - 1.0 / RATE) < 1e-5 / RATE  # 4-decimal stamps pin 256 samples' period to ~2e-6
    assert abs(m.start) < 0.5e-4
    assert "least-squares base" in m.notes["time"]
