"""Each effect's feature-spec extension: the features it adds, the scales it takes from the fit rows, and why an
effect cannot be added when it cannot."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from nnfmu.data import Measurement
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.diagnosis import EFFECTS, DiagnosisSettings, Extension, NoExtension
from nnfmu.models.features import FeatureSpec, SmoothSign, Tap

SPEC = FeatureSpec((Tap("velocity", (0, 2)),), "force")


@cache
def rig() -> Measurement:
    return simulate_rig(
        "damper", RigOptions(duration=6.0, seed=2, excitation="random", effects=("inertia", "temperature"))
    ).measurement


@pytest.mark.parametrize(
    ("effect", "added"),
    [
        ("gas_force", ["displacement[k]"]),
        ("inertia", ["velocity[k-1]"]),
        ("hysteresis", ["lowpass(velocity, tau=0.002)", "lowpass(velocity, tau=0.02)"]),
        ("temperature", ["temperature[k]"]),
        ("frequency_dependence", [f"lowpass(displacement, tau={t!r})" for t in (0.01, 0.1, 1.0)]),
        ("amplitude_dependence", ["lowpass_square(displacement, tau=1.0)"]),
    ],
)
def test_each_effect_extends_the_spec_with_its_features(effect, added):
    m = rig()
    ext = EFFECTS[effect].extension(SPEC, m, np.arange(len(m)), DiagnosisSettings())
    assert isinstance(ext, Extension)
    assert list(ext.added) == added
    assert [n for n in ext.spec.feature_names if n not in added] == SPEC.feature_names  # old features kept


def test_seal_friction_scale_follows_the_fit_rows_rms_velocity():
    m = rig()
    rows = np.arange(1000)
    ext = EFFECTS["seal_friction"].extension(SPEC, m, rows, DiagnosisSettings(friction_scales=(0.05,)))
    (feature,) = ext.spec.derived
    assert isinstance(feature, SmoothSign)
    assert feature.scale == pytest.approx(0.05 * np.sqrt(np.mean(m["velocity"][rows] ** 2)))


def test_temperature_without_its_channel_becomes_a_running_mean_square_of_velocity():
    m = rig()
    channels = {k: v for k, v in m.channels.items() if k != "temperature"}
    bare = Measurement(m.time, channels, {k: m.units[k] for k in channels}, m.source)
    ext = EFFECTS["temperature"].extension(SPEC, bare, np.arange(len(m)), DiagnosisSettings(thermal_tau=200.0))
    assert ext.added == ("lowpass_square(velocity, tau=200.0)",)


def test_effects_that_cannot_be_added_say_why():
    m = rig()
    rows = np.arange(len(m))
    offset = EFFECTS["sensor_offset"].extension(SPEC, m, rows, DiagnosisSettings())
    assert isinstance(offset, NoExtension) and "measurement, not to the component" in offset.reason
    channels = {"velocity": m["velocity"], "force": m["force"]}
    bare = Measurement(m.time, channels, {k: m.units[k] for k in channels}, m.source)
    gas = EFFECTS["gas_force"].extension(SPEC, bare, rows, DiagnosisSettings())
    assert isinstance(gas, NoExtension) and gas.missing_channels == ("displacement",)
    spec = FeatureSpec((Tap("velocity", (0, 1)),), "force")
    again = EFFECTS["inertia"].extension(spec, bare, rows, DiagnosisSettings())
    assert isinstance(again, NoExtension) and "already has" in again.reason
