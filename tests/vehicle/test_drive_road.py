"""Drive-file generator: ISO 8608 PSD level and slope, class steps, track coherence, axle delay, events, rig filter."""

import math

import numpy as np
import pytest
from scipy import integrate, signal

from nnfmu.vehicle.drive import (
    CHANNELS,
    CLASS_LEVELS,
    DriveError,
    DriveSettings,
    KerbStrike,
    Pothole,
    generate_drive,
    track_coherence,
)
from nnfmu.vehicle.drive.rig_filter import controller_gain

UNFILTERED = {"highpass": None, "lowpass": None}
N0 = 0.1  # ISO 8608 reference spatial frequency [cycles/m]


def _spatial_psd(values, settings, nperseg=2**14):
    """One-sided PSD [m^3] over spatial frequency [cycles/m] of a track sampled every settings.spacing metres."""
    return signal.welch(values, fs=1.0 / settings.spacing, nperseg=nperseg)


def test_class_levels_are_the_iso_8608_geometric_means():
    assert CLASS_LEVELS["A"] == pytest.approx(16e-6)
    assert CLASS_LEVELS["C"] == pytest.approx(256e-6)
    assert CLASS_LEVELS["H"] == pytest.approx(16e-6 * 4**7)


@pytest.mark.parametrize("channel", ["actuator_rl_displacement", "actuator_fr_displacement"])
def test_profile_psd_has_slope_minus_two_and_the_class_level(channel):
    settings = DriveSettings(road_class="C", **UNFILTERED)
    n, psd = _spatial_psd(generate_drive(settings)[channel], settings)
    band = (n >= 0.05) & (n <= 5.0)
    slope, _ = np.polyfit(np.log(n[band]), np.log(psd[band]), 1)
    # Level at n0 with the ISO slope imposed: the mean of Gd(n) (n / n0)^2 over the band.
    level = np.mean(psd[band] * (n[band] / N0) ** 2)
    # Amplitudes are exact per frequency; what scatter there is comes from the Welch estimate (measured: slope
    # within 0.02 of -2 and level within 1 % of Gd(n0) for seeds 0-4).
    assert slope == pytest.approx(-2.0, abs=0.05)
    assert level == pytest.approx(CLASS_LEVELS["C"], rel=0.05)


def test_class_d_has_four_times_the_psd_of_class_c():
    ratios = []
    for seed_c, seed_d in ((0, 1), (2, 3)):
        c = DriveSettings(road_class="C", seed=seed_c, **UNFILTERED)
        d = DriveSettings(road_class="D", seed=seed_d, **UNFILTERED)
        n, psd_c = _spatial_psd(generate_drive(c)["actuator_rl_displacement"], c)
        _, psd_d = _spatial_psd(generate_drive(d)["actuator_rl_displacement"], d)
        band = (n >= 0.05) & (n <= 5.0)
        # Both spectra flattened by n^2 so every frequency weighs alike (measured: 3.89-4.04 for seeds 0-5).
        ratios.append(np.mean(psd_d[band] * n[band] ** 2) / np.mean(psd_c[band] * n[band] ** 2))
    assert ratios == pytest.approx([4.0, 4.0], rel=0.1)


def test_isotropic_coherence_matches_the_integral_over_the_surface_spectrum():
    # An isotropic surface whose track PSD falls as n^-2 has the 2-D spectrum |kappa|^-3; two tracks b apart have
    # the cross-spectrum of that spectrum weighted by cos(2 pi m b) over the lateral frequency m.
    b = 1.6
    for n in (0.02, 0.1, 0.3, 1.0):
        auto = integrate.quad(lambda m: (n**2 + m**2) ** -1.5, -np.inf, np.inf)[0]
        cross = integrate.quad(lambda m: (n**2 + m**2) ** -1.5, 0, np.inf, weight="cos", wvar=2 * np.pi * b)[0] * 2
        assert track_coherence(np.array([n]), b, "isotropic")[0] == pytest.approx(cross / auto, abs=1e-7)


def test_generated_tracks_have_the_model_coherence():
    bands = ((0.04, 0.08), (0.08, 0.16), (0.16, 0.32), (1.0, 5.0))
    estimate = np.zeros(len(bands))
    model = np.zeros(len(bands))
    seeds = (0, 1)
    for seed in seeds:
        settings = DriveSettings(duration=200.0, seed=seed, **UNFILTERED)
        m = generate_drive(settings)
        n, msc = signal.coherence(
            m["actuator_rl_displacement"], m["actuator_rr_displacement"], fs=1.0 / settings.spacing, nperseg=4096
        )
        for i, (low, high) in enumerate(bands):
            inside = (n >= low) & (n <= high)
            estimate[i] += msc[inside].mean() / len(seeds)
            model[i] = np.mean(track_coherence(n[inside], settings.track_width, "isotropic") ** 2)
    # Welch coherence over ~100 segments: bias about 0.01, scatter across seeds up to 0.035 (measured, seeds 0-11).
    assert estimate == pytest.approx(model, abs=0.05)
    assert model[0] > 0.5 and model[-1] < 1e-3  # the bands span correlated long waves and independent short ones


def test_identical_tracks_are_equal_and_independent_ones_are_not():
    same = generate_drive(DriveSettings(duration=10.0, coherence="identical"))
    np.testing.assert_array_equal(same["actuator_fl_displacement"], same["actuator_fr_displacement"])
    apart = generate_drive(DriveSettings(duration=10.0, coherence="independent"))
    r = np.corrcoef(apart["actuator_fl_displacement"], apart["actuator_fr_displacement"])[0, 1]
    assert abs(r) < 0.5


def test_rear_channels_are_the_front_ones_delayed_by_wheelbase_over_speed():
    settings = DriveSettings()  # 2.8 m at 20 m/s: 0.14 s = 140 samples
    m = generate_drive(settings)
    delay = round(settings.wheelbase / settings.speed * settings.sample_rate)
    assert delay == 140
    for front, rear in (
        ("actuator_fl_displacement", "actuator_rl_displacement"),
        ("actuator_fr_displacement", "actuator_rr_displacement"),
    ):
        xcorr = signal.correlate(m[rear], m[front], method="fft")
        lags = signal.correlation_lags(len(m[rear]), len(m[front]))
        assert lags[np.argmax(xcorr)] == delay
        scale = np.max(np.abs(m[front]))
        np.testing.assert_allclose(m[rear][delay:], m[front][:-delay], rtol=0, atol=1e-12 * scale)


def test_a_fractional_sample_delay_is_exact():
    settings = DriveSettings(speed=15.0)  # 2.8 m / 15 m/s = 186.67 samples
    m = generate_drive(settings)
    f, cross = signal.csd(m["actuator_fl_displacement"], m["actuator_rl_displacement"], fs=1000.0, nperseg=2**14)
    band = (f > 1.0) & (f < 30.0)
    # A delay tau turns the cross-spectrum phase by -2 pi f tau; this estimate's own bias is ~0.005 samples.
    tau = -np.polyfit(2 * np.pi * f[band], np.unwrap(np.angle(cross[band])), 1)[0]
    assert tau * settings.sample_rate == pytest.approx(2.8 / 15.0 * 1000.0, abs=0.02)


def test_same_seed_gives_the_same_drive_and_another_seed_another():
    a = generate_drive(DriveSettings(duration=5.0, seed=3))
    b = generate_drive(DriveSettings(duration=5.0, seed=3))
    c = generate_drive(DriveSettings(duration=5.0, seed=4))
    assert list(a.channels) == list(CHANNELS)
    assert all(a.units[name] == "m" for name in CHANNELS)
    for name in CHANNELS:
        np.testing.assert_array_equal(a[name], b[name])
        assert not np.allclose(a[name], c[name])


def test_events_appear_at_their_time_with_their_size():
    events = (
        Pothole(time=10.0, depth=0.05, length=0.6, side="left"),
        KerbStrike(time=20.0, height=0.1, ramp_length=0.1, length=2.0, side="right"),
    )
    settings = DriveSettings(events=events, **UNFILTERED)
    with_events = generate_drive(settings)
    road = generate_drive(DriveSettings(**UNFILTERED))
    delta = {name: with_events[name] - road[name] for name in CHANNELS}
    rate, axle_delay = settings.sample_rate, settings.axle_delay
    # Pothole: deepest when each axle is at its centre, only on the left.
    assert delta["actuator_fl_displacement"][round(10.0 * rate)] == pytest.approx(-0.05, abs=1e-12)
    assert delta["actuator_rl_displacement"][round((10.0 + axle_delay) * rate)] == pytest.approx(-0.05, abs=1e-12)
    assert np.argmin(delta["actuator_fl_displacement"]) == round(10.0 * rate)
    # Kerb: half height at the middle of the climb, full height on the kerb, only on the right.
    on_kerb = (20.0 + 1.0 / settings.speed) * rate
    assert delta["actuator_fr_displacement"][round(20.0 * rate)] == pytest.approx(0.05, abs=1e-12)
    assert delta["actuator_fr_displacement"][round(on_kerb)] == pytest.approx(0.1, abs=1e-12)
    assert delta["actuator_rr_displacement"][round(on_kerb + axle_delay * rate)] == pytest.approx(0.1, abs=1e-12)
    assert np.max(np.abs(delta["actuator_fr_displacement"][: round(19.9 * rate)])) < 1e-12
    # Each event only in its own track.
    assert np.max(np.abs(delta["actuator_fl_displacement"][round(15 * rate) :])) < 1e-12
    assert np.max(np.abs(delta["actuator_fr_displacement"][: round(15 * rate)])) < 1e-12


def test_the_rig_band_limit_keeps_an_event_at_its_time():
    pothole = Pothole(time=10.0, depth=0.05, length=1.0, side="both")
    settings = DriveSettings(events=(pothole,))
    delta = (
        generate_drive(settings)["actuator_fr_displacement"]
        - generate_drive(DriveSettings())["actuator_fr_displacement"]
    )
    # Zero-phase filtering: the dip stays centred; a 1 m dip at 20 m/s (50 ms) keeps most of its depth below 40 Hz.
    assert np.argmin(delta) == round(10.0 * settings.sample_rate)
    assert -np.min(delta) == pytest.approx(0.05, rel=0.1)


def test_the_rig_filter_is_a_zero_phase_butterworth_band():
    filtered_settings = DriveSettings()
    filtered = generate_drive(filtered_settings)["actuator_rl_displacement"]
    raw = generate_drive(DriveSettings(**UNFILTERED))["actuator_rl_displacement"]
    f, p_filtered = signal.welch(filtered, fs=1000.0, nperseg=8192)
    _, p_raw = signal.welch(raw, fs=1000.0, nperseg=8192)
    high = signal.butter(4, 2 * np.pi * 0.5, "highpass", analog=True)
    low = signal.butter(4, 2 * np.pi * 40.0, "lowpass", analog=True)
    gain = np.abs(signal.freqs(*high, 2 * np.pi * f)[1] * signal.freqs(*low, 2 * np.pi * f)[1])
    band = (f >= 1.0) & (f <= 150.0)
    np.testing.assert_allclose(p_filtered[band] / p_raw[band], gain[band] ** 2, rtol=0.02)


def test_controller_gain_is_the_analog_butterworth_magnitude():
    settings = DriveSettings(highpass=0.5, lowpass=40.0, filter_order=3)
    f = np.array([0.0, 0.05, 0.2, 0.5, 1.0, 10.0, 40.0, 100.0, 400.0])
    high = signal.butter(3, 2 * np.pi * 0.5, "highpass", analog=True)
    low = signal.butter(3, 2 * np.pi * 40.0, "lowpass", analog=True)
    expected = np.abs(signal.freqs(*high, 2 * np.pi * f)[1] * signal.freqs(*low, 2 * np.pi * f)[1])
    np.testing.assert_allclose(controller_gain(f, settings), expected, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize(
    ("settings", "named"),
    [
        (DriveSettings(road_class="Z"), "'Z'"),
        (DriveSettings(road_class="c"), "'c'"),
        (DriveSettings(speed=-5.0), "-5.0"),
        (DriveSettings(speed=math.nan), "speed"),
        (DriveSettings(duration=0.0), "duration"),
        (DriveSettings(coherence="perfect"), "'perfect'"),
        (DriveSettings(lowpass=600.0), "600"),
        (DriveSettings(highpass=50.0), "highpass 50"),
        (DriveSettings(band=(5.0, 1.0)), "band"),
        (DriveSettings(seed=-1), "seed"),
        (DriveSettings(events=(Pothole(time=10.0, depth=-0.05),)), "-0.05"),
        (DriveSettings(events=(Pothole(time=10.0, side="middle"),)), "'middle'"),
        (DriveSettings(events=(Pothole(time=49.99),)), "rear axle leaves"),
        (DriveSettings(events=(KerbStrike(time=0.0),)), "before the drive starts"),
        (DriveSettings(duration=2.0, fade_in=3.0), "fade_in"),
        (DriveSettings(fade_in=-0.5), "-0.5"),
    ],
)
def test_bad_settings_raise_an_error_naming_the_value(settings, named):
    with pytest.raises(DriveError) as error:
        generate_drive(settings)
    assert named in str(error.value)


def test_a_faded_in_drive_starts_at_rest_and_is_the_road_after_the_fade():
    """The weight and its slope are zero at t = 0 (a car at rest on the rig sees no step), one from fade_in on."""
    plain = generate_drive(DriveSettings(duration=3.0))
    faded = generate_drive(DriveSettings(duration=3.0, fade_in=0.5))
    after = plain.time >= 0.5
    for channel in CHANNELS:
        assert abs(plain[channel][0]) > 1e-4  # m: the road's own height at the first sample
        assert faded[channel][0] == 0.0 and abs(faded[channel][1]) < 1e-6
        np.testing.assert_array_equal(faded[channel][after], plain[channel][after])
    assert "0.5 s" in faded.notes["fade_in"] and plain.notes["fade_in"] == "none"
