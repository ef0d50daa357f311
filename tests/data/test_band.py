"""The band a record excites: its upper edge against the frequencies the signal is made of, and against a plain
periodogram's cumulative power (an independent estimate); the share of a signal's power above an edge; bad signals
refused."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from nnfmu.data.band import BAND_POWER_SHARE, excited_band, power_above

RATE = 1000.0


def _time(seconds: float) -> np.ndarray:
    return np.arange(int(seconds * RATE)) / RATE


def test_the_edge_is_the_highest_tone_holding_power() -> None:
    t = _time(20.0)
    assert excited_band(np.sin(2 * np.pi * 10.0 * t), 1 / RATE) == pytest.approx(10.0, abs=0.5)
    two = 3.0 + np.sin(2 * np.pi * 5.0 * t) + np.sin(2 * np.pi * 30.0 * t)  # the mean is not power
    assert excited_band(two, 1 / RATE) == pytest.approx(30.0, abs=0.5)
    # a 30 Hz tone with a thousandth of the power is below the 1 % the edge leaves out
    faint = np.sin(2 * np.pi * 5.0 * t) + 0.03 * np.sin(2 * np.pi * 30.0 * t)
    assert excited_band(faint, 1 / RATE) == pytest.approx(5.0, abs=0.5)


def test_random_drive_edge_agrees_with_a_plain_periodogram() -> None:
    noise = np.random.default_rng(3).standard_normal(60_000)
    x = sosfiltfilt(butter(8, 40.0, fs=RATE, output="sos"), noise)
    power = np.abs(np.fft.rfft(x - x.mean())) ** 2
    frequency = np.fft.rfftfreq(len(x), 1 / RATE)
    reference = frequency[np.searchsorted(np.cumsum(power), 0.99 * power.sum())]
    edge = excited_band(x, 1 / RATE)
    assert 30.0 < edge < 45.0
    assert edge == pytest.approx(reference, abs=0.5)  # Welch's 0.25 Hz bins against the whole record's


def test_a_signal_that_does_not_move_excites_no_band_and_bad_input_is_refused() -> None:
    assert excited_band(np.full(1000, 2.5), 1 / RATE) == 0.0
    with pytest.raises(ValueError, match="finite 1-D"):
        excited_band(np.array([0.0, np.nan, 1.0]), 1 / RATE)
    with pytest.raises(ValueError, match="sample period"):
        excited_band(np.arange(10.0), 0.0)
    assert excited_band(np.sin(np.arange(100) * 0.5), 1 / RATE) > 0  # shorter than a segment: one segment


def test_the_share_of_power_above_an_edge() -> None:
    t = _time(20.0)
    two = np.sin(2 * np.pi * 5.0 * t) + np.sin(2 * np.pi * 30.0 * t)
    assert power_above(two, 1 / RATE, 10.0) == pytest.approx(0.5, abs=0.01)
    assert power_above(two, 1 / RATE, 40.0) < 1e-4 and power_above(two, 1 / RATE, 1.0) > 0.999
    # a record holds 1 - BAND_POWER_SHARE of its power above its own band's edge, to a bin
    x = sosfiltfilt(butter(8, 40.0, fs=RATE, output="sos"), np.random.default_rng(5).standard_normal(60_000))
    assert power_above(x, 1 / RATE, excited_band(x, 1 / RATE)) == pytest.approx(1 - BAND_POWER_SHARE, abs=0.003)
    assert power_above(np.zeros(100), 1 / RATE, 10.0) == 0.0
    with pytest.raises(ValueError, match="band edge"):
        power_above(two, 1 / RATE, float("nan"))
