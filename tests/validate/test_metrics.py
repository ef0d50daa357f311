"""Metric definitions on analytic cases, Welch PSD against Parseval, and channel comparison of Measurements."""

import numpy as np
import pytest

from nnfmu.data import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.validate import metrics
from nnfmu.validate.compare import ValidationError, ValidationSettings, compare, quantity_of
from nnfmu.validate.spectra import welch_psd
from nnfmu.validate.summary import channel_metrics

DT = 0.005  # 200 Hz, as a road test simulator record


def load_signal(duration: float = 20.0, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A force-like signal [N]: two sines plus smoothed noise, with a nonzero mean."""
    t = np.arange(0.0, duration, DT)
    rng = np.random.default_rng(seed)
    noise = np.convolve(rng.normal(size=t.size), np.ones(9) / 9, mode="same")
    return t, 400.0 + 1500.0 * np.sin(2 * np.pi * 1.3 * t) + 300.0 * np.sin(2 * np.pi * 11.0 * t) + 200.0 * noise


def measurement(t: np.ndarray, source: str, **channels: np.ndarray) -> Measurement:
    units = {"force": "N", "axial_force": "N", "displacement": "m"}
    return Measurement(time=t, channels=dict(channels), units={k: units[k] for k in channels}, source=source)


# --- metric definitions ---------------------------------------------------------------------------------------


def test_identical_signals_are_a_perfect_match():
    _, y = load_signal()
    m = channel_metrics(y, y.copy(), slope=5.0)
    assert m.nrmse == 0.0
    assert m.r2 == 1.0
    assert m.mean_shift == 0.0
    assert m.peak_error == 0.0
    for ratio in (m.peak_ratio, m.valley_ratio, m.rms_ratio, m.pseudo_damage_ratio):
        assert ratio == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("slope", [3.0, 5.0])
def test_scaled_signal(slope):
    _, y = load_signal()
    m = channel_metrics(1.1 * y, y, slope=slope)
    assert m.peak_ratio == pytest.approx(1.1, rel=1e-12)
    assert m.valley_ratio == pytest.approx(1.1, rel=1e-12)
    assert m.rms_ratio == pytest.approx(1.1, rel=1e-12)
    assert m.peak_error == pytest.approx(0.1, rel=1e-9)
    assert m.nrmse == pytest.approx(0.1, rel=1e-9)  # RMS(0.1 y) / RMS(y)
    assert m.mean_shift == pytest.approx(0.1 * np.mean(y), rel=1e-9)
    assert m.pseudo_damage_ratio == pytest.approx(1.1**slope, rel=1e-9)
    assert m.pseudo_damage_result == pytest.approx(1.1**slope * m.pseudo_damage_reference, rel=1e-9)


def test_constant_offset():
    _, y = load_signal()
    offset = 123.0
    m = channel_metrics(y + offset, y, slope=5.0)
    assert m.mean_shift == pytest.approx(offset, rel=1e-12)
    assert m.pseudo_damage_ratio == pytest.approx(1.0, rel=1e-9)
    assert m.peak_ratio == pytest.approx((y.max() + offset) / y.max(), rel=1e-12)
    assert m.valley_ratio == pytest.approx((y.min() + offset) / y.min(), rel=1e-12)
    # SS_res = n * offset^2, SS_tot = n * var(y)
    assert m.r2 == pytest.approx(1.0 - offset**2 / np.var(y), rel=1e-12)
    assert m.nrmse == pytest.approx(offset / np.sqrt(np.mean(y**2)), rel=1e-12)


def test_zero_result_has_nrmse_one_and_all_zero_reference_gives_nan():
    _, y = load_signal()
    assert metrics.nrmse(np.zeros_like(y), y) == pytest.approx(1.0)
    assert np.isnan(metrics.nrmse(y, np.zeros_like(y)))
    assert np.isnan(metrics.r2(y, np.zeros_like(y)))


def test_every_metric_has_a_definition():
    fields = set(channel_metrics(np.array([0.0, 1.0, 0.0]), np.array([0.0, 2.0, 0.0]), 5.0).to_dict())
    assert set(metrics.DEFINITIONS) == fields - {"pseudo_damage_result", "pseudo_damage_reference", "not_meaningful"}


def test_error_summary_holds_the_loop_stage_numbers():
    _, y = load_signal()
    summary = channel_metrics(0.9 * y, y, 5.0).error_summary()
    assert set(summary) == {"nrmse", "r2", "peak_error", "pseudo_damage_ratio"}
    assert summary["peak_error"] == pytest.approx(-0.1)


# --- PSD ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("frequency", [3.0, 7.25, 21.5])
def test_psd_of_sine_peaks_at_its_frequency_and_integrates_to_its_variance(frequency):
    t = np.arange(0.0, 60.0, DT)
    amplitude = 2.0
    x = 5.0 + amplitude * np.sin(2 * np.pi * frequency * t + 0.3)
    psd = welch_psd(x, DT, fmax=50.0, resolution=0.25)
    assert psd.frequency[np.argmax(psd.density)] == pytest.approx(frequency, abs=0.25)
    variance = np.sum(psd.density) * (psd.frequency[1] - psd.frequency[0])
    assert variance == pytest.approx(amplitude**2 / 2, rel=0.02)  # Parseval; the mean 5 is removed


def test_psd_stops_at_fmax_and_white_noise_integrates_to_its_variance():
    rng = np.random.default_rng(0)
    x = rng.normal(scale=3.0, size=40000)
    full = welch_psd(x, DT, fmax=100.0)
    assert full.frequency[-1] == pytest.approx(100.0)
    assert np.sum(full.density) * (full.frequency[1] - full.frequency[0]) == pytest.approx(9.0, rel=0.03)
    assert welch_psd(x, DT, fmax=50.0).frequency.max() <= 50.0


# --- comparing measurements -----------------------------------------------------------------------------------


def test_compare_identical_measurements():
    t, y = load_signal()
    [c] = compare(measurement(t, "result.csv", force=y.copy()), measurement(t, "ref.csv", force=y), ["force"])
    assert (c.name, c.unit, c.quantity, c.basquin_slope) == ("force", "N", "force", 5.0)
    assert c.metrics.nrmse == 0.0 and c.metrics.r2 == 1.0
    assert c.metrics.pseudo_damage_ratio == pytest.approx(1.0, rel=1e-12)


def test_missing_channel_names_channel_and_file():
    t, y = load_signal()
    with pytest.raises(ValidationError, match=r"result\.csv: no channel 'axial_force'"):
        compare(
            measurement(t, "result.csv", force=y),
            measurement(t, "ref.csv", force=y, axial_force=y),
            ["force", "axial_force"],
        )


def test_unit_mismatch_names_channel_and_both_units():
    t, y = load_signal()
    result = measurement(t, "result.csv", force=y)
    result.units["force"] = "N.m"
    with pytest.raises(DataError, match=r"channel 'force': unit 'N\.m' in result\.csv but 'N' in ref\.csv"):
        compare(result, measurement(t, "ref.csv", force=y), ["force"])


def test_non_finite_values_are_refused():
    t, y = load_signal()
    bad = y.copy()
    bad[10] = np.nan
    with pytest.raises(ValidationError, match=r"result\.csv: channel 'force' holds NaN"):
        compare(measurement(t, "result.csv", force=bad), measurement(t, "ref.csv", force=y), ["force"])


def test_result_on_other_time_base_is_interpolated_onto_reference_within_overlap():
    t_ref = np.arange(0.0, 20.0, DT)
    t_res = np.arange(1.0, 25.0, 0.002)  # faster, starts later, ends later
    f = lambda t: 1000.0 * np.sin(2 * np.pi * 0.7 * t)  # noqa: E731
    [c] = compare(
        measurement(t_res, "result.csv", force=f(t_res)), measurement(t_ref, "ref.csv", force=f(t_ref)), ["force"]
    )
    assert c.time[0] == pytest.approx(1.0) and c.time[-1] == pytest.approx(t_ref[-1])
    np.testing.assert_array_equal(c.reference, f(c.time))
    assert c.metrics.nrmse < 1e-4  # only linear-interpolation error of a 0.7 Hz sine sampled at 500 Hz


def test_disjoint_time_spans_are_refused():
    t = np.arange(0.0, 1.0, DT)
    with pytest.raises(ValidationError, match="share fewer than 2"):
        compare(
            measurement(t + 5.0, "result.csv", force=np.sin(t)), measurement(t, "ref.csv", force=np.sin(t)), ["force"]
        )


def test_window_is_centred_on_the_global_peak_and_clipped_to_the_record():
    t, y = load_signal()
    y[int(12.0 / DT)] = 1e5  # global peak at 12 s
    y[int(0.5 / DT)] = -2e5  # larger magnitude near the start: window shifts to start at 0
    m = measurement(t, "ref.csv", force=y)
    [c] = compare(m, m, ["force"], ValidationSettings(window_length=5.0))
    assert c.window == pytest.approx((0.0, 5.0))
    y[int(0.5 / DT)] = 0.0
    [c] = compare(m, m, ["force"], ValidationSettings(window_length=5.0))
    assert c.window == pytest.approx((9.5, 14.5))
    [c] = compare(m, m, ["force"], ValidationSettings(window=(3.0, 8.0)))
    assert c.window == (3.0, 8.0)
    with pytest.raises(ValidationError, match=r"channel 'force': window \(30.0, 35.0\) s lies outside"):
        compare(m, m, ["force"], ValidationSettings(window=(30.0, 35.0)))  # beyond a 20 s record


def test_quantity_from_base_name():
    assert quantity_of("axial_force") == "force"
    assert quantity_of("axial_angular_velocity") == "angular_velocity"
    assert quantity_of("conical_velocity") == "velocity"
    assert quantity_of("lca_angle") == "angle"
    assert quantity_of("stroke_ratio") == "stroke_ratio"


def test_basquin_slope_per_channel_over_quantity_over_default():
    settings = ValidationSettings(basquin_slope=5.0, slopes={"displacement": 3.0, "radial_displacement": 4.0})
    assert settings.slope_for("axial_force") == 5.0
    assert settings.slope_for("axial_displacement") == 3.0
    assert settings.slope_for("radial_displacement") == 4.0
    with pytest.raises(ValidationError, match="'force'"):
        ValidationSettings(slopes={"force": -1.0})


def test_slope_setting_reaches_the_damage_ratio():
    t, y = load_signal()
    result = measurement(t, "result.csv", force=1.1 * y, displacement=1.1 * y * 1e-5)
    reference = measurement(t, "ref.csv", force=y, displacement=y * 1e-5)
    force, displacement = compare(
        result, reference, ["force", "displacement"], ValidationSettings(slopes={"displacement": 3.0})
    )
    assert force.metrics.pseudo_damage_ratio == pytest.approx(1.1**5, rel=1e-9)
    assert displacement.metrics.pseudo_damage_ratio == pytest.approx(1.1**3, rel=1e-9)
