"""A network input's use of its training envelope and band along a run: the range against the port's, the share of
the signal's power above the band its record excited, and the rows the road test's report marks."""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.component import Port
from nnfmu.data.band import power_above
from nnfmu.workflows.roadtest.envelope import BAND_WARN_SHARE, envelope_warnings, excursion

PERIOD = 1e-3


def _signal(high_share: float) -> np.ndarray:
    """A 5 Hz tone with a 60 Hz one holding `high_share` of the power, 10 s at 1 kHz."""
    t = np.arange(10_000) * PERIOD
    return np.sqrt(1 - high_share) * np.sin(2 * np.pi * 5 * t) + np.sqrt(high_share) * np.sin(2 * np.pi * 60 * t)


@pytest.mark.parametrize("high_share", [0.02, 0.2])
def test_the_power_above_the_band_is_measured_and_marked_past_the_warn_share(high_share: float) -> None:
    port = Port("radial_velocity", "m/s", min=-2.0, max=2.0)
    used = excursion("reference", "bushing_fl_front", port, _signal(high_share), 39.5, PERIOD)
    assert used.power_above_band == pytest.approx(high_share, abs=1e-3)
    assert used.power_above_band == power_above(_signal(high_share), PERIOD, 39.5)
    assert used.above_band is (high_share > BAND_WARN_SHARE) and used.share_outside == 0.0
    row = used.to_dict()
    assert (row["band_edge"], row["above_band"]) == (39.5, used.above_band)


def test_without_a_band_nothing_is_said_about_frequency_and_a_band_needs_the_sample_period() -> None:
    port = Port("radial_velocity", "m/s", min=-0.5, max=0.5)
    used = excursion("reference", "bushing_fl_front", port, _signal(0.2))
    assert used.power_above_band is None and not used.above_band and used.share_outside > 0
    assert used.to_dict()["power_above_band"] is None
    with pytest.raises(ValueError, match="sample period"):
        excursion("reference", "bushing_fl_front", port, _signal(0.2), 39.5)


def test_the_road_test_warns_of_each_input_beyond_its_envelope_or_above_its_band() -> None:
    wide = Port("radial_velocity", "m/s", min=-2.0, max=2.0)
    narrow = Port("axial_velocity", "m/s", min=-0.5, max=0.5)
    used = [
        excursion("reference", "bushing_fl_front", wide, _signal(0.02), 39.5, PERIOD),  # inside both: no line
        excursion("reference", "bushing_fl_front", wide, _signal(0.2), 39.5, PERIOD),
        excursion("reference", "bushing_fl_rear", narrow, _signal(0.02), 39.5, PERIOD),
    ]
    lines = envelope_warnings("full-vehicle", used)
    assert lines == [
        f"full-vehicle, reference: bushing_fl_front.radial_velocity held {used[1].power_above_band:.1%} of its power "
        "above 39.5 Hz, the band its training record excited (which held 1% there): the network extrapolates in "
        "frequency",
        f"full-vehicle, reference: bushing_fl_rear.axial_velocity reached {used[2].signal_min:.4g} to "
        f"{used[2].signal_max:.4g} m/s, {used[2].range_used:.2f}x its training envelope [-0.5, 0.5] m/s, on "
        f"{used[2].share_outside:.2%} of the run: the network extrapolates there",
    ]
