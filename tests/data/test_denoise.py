"""Zero-phase low-pass of input channels: the motion in the rig's band kept in amplitude and phase, the transducer
noise above it removed, bad settings refused with the record named."""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.data.denoise import lowpass_channels
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement

RATE = 1000.0


def record(n: int = 20000, noise: float = 0.01) -> tuple[Measurement, np.ndarray]:
    t = np.arange(n) / RATE
    motion = np.sin(2 * np.pi * 20 * t) + 0.5 * np.sin(2 * np.pi * 3 * t)  # inside a 40 Hz rig band
    noisy = motion + noise * np.random.default_rng(1).standard_normal(n)
    channels = {"rotation": noisy, "torque": 3.0 * noisy}
    return Measurement(t, channels, {"rotation": "rad", "torque": "N.m"}, source="rig.csv"), motion


def test_the_band_is_kept_without_lag_and_the_noise_above_it_removed():
    m, motion = record()
    out = lowpass_channels(m, ["rotation"], 100.0)
    inner = slice(1000, -1000)
    residual = out["rotation"][inner] - motion[inner]
    assert np.std(residual) < 0.5 * 0.01  # white noise to 500 Hz, kept below 100 Hz: ~0.45 of it
    assert abs(np.mean(residual * np.cos(2 * np.pi * 20 * m.time[inner]))) < 1e-4  # no phase lag at 20 Hz
    np.testing.assert_array_equal(out["torque"], m["torque"])  # only the named channels
    assert "100 Hz" in out.notes["lowpass:rotation"]


def test_none_keeps_the_record_and_bad_settings_name_the_file():
    m, _ = record()
    assert lowpass_channels(m, ["rotation"], None) is m
    with pytest.raises(DataError, match="rig.csv: input low-pass cut-off 500.0 Hz"):
        lowpass_channels(m, ["rotation"], 500.0)
    with pytest.raises(DataError, match="rig.csv: no channel 'angle'"):
        lowpass_channels(m, ["angle"], 100.0)
    with pytest.raises(DataError, match="too few to low-pass"):
        lowpass_channels(record(n=12)[0], ["rotation"], 100.0)
