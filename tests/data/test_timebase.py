"""Time stamps with print rounding: resolution inferred from the text, uniform base fitted, gaps and drift refused."""

import numpy as np
import pytest
from asammdf import MDF, Signal

from nnfmu.data import DataError, load_measurement
from nnfmu.data.timebase import TIME_JITTER, printed_resolution

RATE = 1024.0  # Hz: the period 0.9765625 ms has no short decimal form, so printed stamps are rounded


def _eight_digits(value: float) -> str:
    """A stamp as an MTS controller prints it: 8 significant digits, trailing zeros kept."""
    return f"{value:#.8g}"


def _write(path, time, fmt=_eight_digits):
    """A CSV dyno record (stroke in inches, load in lbf) with the stamps printed by `fmt`."""
    x = 1.5 * np.sin(2 * np.pi * 1.3 * time)
    rows = "".join(f"{fmt(t)},{a:.6g},{400 * a:.6g}\n" for t, a in zip(time, x))
    path.write_text("time [s],displacement [in],force [lbf]\n" + rows, encoding="utf-8")
    return path


def test_resolution_of_eight_significant_digits_grows_with_the_stamp():
    values = np.array([0.5, 1.5, 12.5, 123.5, 0.0])
    cells = ["0.50000000", "1.5000000", "12.500000", "123.50000", "0.0000000"]
    resolution = printed_resolution(cells, values)
    np.testing.assert_allclose(resolution.step[:4], [1e-8, 1e-7, 1e-6, 1e-5], rtol=1e-12)
    assert resolution.format == "printed to 8 significant digits"


def test_resolution_of_fixed_decimals_and_of_dropped_trailing_zeros():
    fixed = printed_resolution(["0.001000", "12.345678", "99.000000"], np.array([0.001, 12.345678, 99.0]))
    np.testing.assert_allclose(fixed.step, 1e-6, rtol=1e-12)
    assert fixed.format == "printed to 6 decimals"
    # `%.8g` drops trailing zeros: '12.5' is still resolved to 1e-6 s, as its neighbours show 8 digits
    stripped = printed_resolution(["12.5", "12.500977", "12.501953"], np.array([12.5, 12.500977, 12.501953]))
    np.testing.assert_allclose(stripped.step, 1e-6, rtol=1e-12)


def test_jitter_within_print_resolution_is_accepted_with_one_note_and_the_fitted_period(tmp_path):
    time = 9.0 + np.arange(70801) / RATE  # like the dyno record of issue #16: 1024 Hz, running time 9 s to 78 s
    steps = np.diff([float(_eight_digits(t)) for t in time])
    median = np.median(steps)  # 977 us: past 10 s the printed steps are 976 or 977 us
    assert np.count_nonzero(np.abs(steps - median) > TIME_JITTER * median) > 30000  # the old per-step rule refused
    m = load_measurement(_write(tmp_path / "mts.csv", time))
    note = m.notes["time"]
    assert "\n" not in note
    assert "within their resolution (printed to 8 significant digits; 1e-06 s at the last stamp)" in note
    assert "base t = 9 s + k * 0.9765625 ms (1024 Hz)" in note
    assert abs(m.sample_period - 1 / RATE) < 1e-12
    np.testing.assert_allclose(m.time, time, rtol=0, atol=1e-9)  # the fitted base, not the rounded stamps
    assert np.max(np.abs(np.diff(m.time) - 1 / RATE)) < 1e-12


def test_a_missing_sample_is_refused_naming_it(tmp_path):
    time = np.delete(np.arange(int(30 * RATE)) / RATE, 20000)
    with pytest.raises(
        DataError,
        match=r"gap\.csv: time is not uniformly sampled at sample 20000 \(t = 19\.532227 s\): the step from the "
        r"previous sample is 0\.00195\d s",
    ):
        load_measurement(_write(tmp_path / "gap.csv", time))


def test_a_drifting_clock_is_refused_naming_the_sample_where_it_starts(tmp_path):
    time = np.arange(int(20 * RATE)) / RATE
    time = np.where(time > 10.0, 10.0 + (time - 10.0) * 1.0005, time)  # every step off by 0.05 %: within jitter
    with pytest.raises(
        DataError,
        match=r"drift\.csv: time is not uniformly sampled at sample 10240 \(t = 10 s\): the stamp lies .* off the "
        r"least-squares uniform base .* stamps lie beyond their tolerance \(a sampling clock that drifts",
    ):
        load_measurement(_write(tmp_path / "drift.csv", time))


def test_one_stamp_off_by_a_unit_of_its_last_digit_is_refused_when_the_others_are_exact(tmp_path):
    time = np.arange(4096) / 1000.0  # milliseconds print exactly (shortest repr): nothing here is rounded
    stamps = [repr(float(t)) for t in time]
    stamps[2000] = "2.0001"  # 0.1 ms late: one unit of its own last digit, 10 % of the period
    path = tmp_path / "late.csv"
    path.write_text("time [s],force [N]\n" + "".join(f"{s},1\n" for s in stamps), encoding="utf-8")
    with pytest.raises(DataError, match=r"late\.csv: time is not uniformly sampled at sample 2000 \(t = 2\.0001 s\)"):
        load_measurement(path)


def test_exact_stamps_are_kept_bit_for_bit_without_a_note(tmp_path):
    time = np.arange(5000) / RATE
    m = load_measurement(_write(tmp_path / "exact.csv", time, fmt=lambda t: repr(float(t))))
    assert np.array_equal(m.time, time)
    assert "time" not in m.notes


def test_float32_mdf_time_is_resolved_to_its_spacing(tmp_path):
    time = (np.arange(80000) / 1000.0).astype(np.float32)  # spacing 7.6e-6 s past 64 s: 0.8 % of the period
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.sin(time.astype(float)), time, name="force", unit="N")])
    mdf.save(str(tmp_path / "f32.mf4"), overwrite=True)
    mdf.close()
    m = load_measurement(tmp_path / "f32.mf4")
    assert "within their resolution (stored as float32" in m.notes["time"]
    assert abs(m.sample_period - 1e-3) < 1e-10


def test_float64_mdf_time_gets_only_the_clock_scatter_tolerance(tmp_path):
    time = np.arange(4096) / RATE
    time[1000:] += 0.2 / RATE  # a fifth of the period from sample 1000 on: four times the clock-scatter tolerance
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.zeros(time.size), time, name="force", unit="N")])
    mdf.save(str(tmp_path / "f64.mf4"), overwrite=True)
    mdf.close()
    with pytest.raises(
        DataError, match=r"f64\.mf4: time is not uniformly sampled at sample 1000 .*by 0\.05 of the period \(a clock's"
    ):
        load_measurement(tmp_path / "f64.mf4")
