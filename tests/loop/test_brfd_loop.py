"""The loop on measured data: the BRFD friction damper with backlash (tests/data/brfd, CC BY-SA 4.0, Coble et al.
2022), from a velocity-only network. The residual is not noise, the effect library's backlash family (stop operators
of displacement) explains it, and its features lower the held-out error. Also the backlash family and extension."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nnfmu.data import Measurement
from nnfmu.data.importers import load_brfd_series
from nnfmu.export import export_onnx
from nnfmu.loop.blocks import part_measurement, plan_blocks
from nnfmu.loop.effects import EFFECTS, backlash_radii, stop_operator
from nnfmu.loop.extend import Extension, NoExtension, extend_spec
from nnfmu.loop.loop_settings import LoopSettings
from nnfmu.loop.run import run_loop
from nnfmu.loop.settings import DiagnosisSettings
from nnfmu.loop.signals import build_signals
from nnfmu.models import Architecture, TrainSettings, train_model
from nnfmu.models.features import FeatureSpec, SmoothSign, Stop, Tap

SLICE = Path(__file__).parents[1] / "data" / "brfd"
RUNS = [SLICE / f"1Hz36lbtension{a}amplitude.json.gz" for a in ("0.5", "1", "1.5")]
# The damper has no gas spring: the diagnosis ranks the other families (as examples/brfd_loop.py --effects does).
EFFECTS_RANKED = tuple(name for name in EFFECTS if name != "gas_force")
# Velocity-only start: force from velocity and its friction sign. (The damper-hysteresis preset's velocity differences
# count samples; at the slice's 256 Hz they span 4x the time they were chosen for at 1 kHz.)
VELOCITY_ONLY = FeatureSpec((Tap("velocity"),), "force", (SmoothSign("velocity", scale=0.01),))


def triangle(period: float = 1.0, amplitude: float = 0.02, dt: float = 0.001, cycles: int = 4) -> Measurement:
    """A triangle-wave displacement [m] and its velocity [m/s]; force 0 (only the channels matter here)."""
    t = np.arange(int(cycles * period / dt)) * dt
    phase = (t / period) % 1.0
    x = amplitude * (4 * np.abs(phase - 0.5) - 1)
    v = np.gradient(x, dt)
    return Measurement(t, {"displacement": x, "velocity": v, "force": np.zeros_like(t)},
                       {"displacement": "m", "velocity": "m/s", "force": "N"}, "triangle")


def test_the_backlash_regressors_are_the_feature_kinds_stop_operators():
    """The diagnosis's stop operator (effects.py) and the step graph's (Stop feature) are written independently; once
    the first reversal has closed the gap they agree to rounding, and both stay within ±radius."""
    m = triangle()
    for radius in (0.001, 0.005):
        diagnosis = stop_operator(m["displacement"], radius)
        feature = FeatureSpec((), "force", (Stop("displacement", radius=radius),)).features(m.channels, 0.001)[:, 0]
        settled = m.time > 0.75  # the first reversal is at 0.5 s; the gap closes 2·radius of travel later
        np.testing.assert_allclose(diagnosis[settled], feature[settled], rtol=0, atol=1e-15)
        assert np.max(np.abs(diagnosis)) == pytest.approx(radius)


def test_the_gap_sizes_follow_the_travel_between_reversals():
    m = triangle(amplitude=0.02)  # travel between reversals 0.04 m
    radii = backlash_radii(m["velocity"], 0.001, (0.1, 0.5))
    assert radii == pytest.approx((0.002, 0.01), rel=0.02)
    signals = build_signals(m, m["force"] + 1.0, "force", ("velocity",))
    regressors = EFFECTS["backlash"].compute(signals, DiagnosisSettings(reversal_fractions=(0.1, 0.5)))
    assert regressors.matrix.shape == (len(m), 2) and regressors.names[0].startswith("stop(displacement, radius=0.002")


def test_the_backlash_extension_adds_stop_states_of_displacement_and_needs_displacement():
    m = triangle(amplitude=0.02)
    spec = FeatureSpec((Tap("velocity"),), "force")
    settings = LoopSettings(diagnosis=DiagnosisSettings(reversal_fractions=(0.1, 0.5)))
    ext = extend_spec("backlash", spec, m, np.arange(len(m)), settings)
    assert isinstance(ext, Extension)
    assert all(name.startswith("stop(displacement, radius=") for name in ext.added) and len(ext.added) == 2
    assert [d.radius for d in ext.spec.derived] == pytest.approx([0.002, 0.01], rel=0.02)
    assert ext.spec.channels == ["velocity", "displacement"] and ext.spec.state_size == 2
    without = Measurement(m.time, {"velocity": m["velocity"], "force": m["force"]}, {"velocity": "m/s", "force": "N"})
    missing = extend_spec("backlash", spec, without, np.arange(len(m)), settings)
    assert isinstance(missing, NoExtension) and missing.missing_channels == ("displacement",)


def test_the_loop_finds_backlash_in_the_measured_damper_and_the_held_out_error_falls(tmp_path):
    m = load_brfd_series(RUNS)  # three 1 Hz runs at 36 lb band tension, 256 Hz, 21 s
    settings = LoopSettings(
        max_effects=1, segments=2 * len(RUNS), max_epochs=60, extra_hidden=(0, 4), lm_max_samples=3000,
        diagnosis=DiagnosisSettings(min_samples=512, effects=EFFECTS_RANKED),
    )
    blocks = plan_blocks(len(m), settings, m.source)
    fit = part_measurement(m, np.concatenate([blocks.rows("train"), blocks.rows("validation")]), "fit")
    model = train_model(fit, VELOCITY_ONLY, Architecture("mlp", (5,)), TrainSettings(restarts=1, max_epochs=80)).model
    onnx_path = tmp_path / "velocity_only.onnx"
    export_onnx(model, onnx_path, name="brfd_force")

    report = run_loop(m, onnx_path, "force", tmp_path / "loop", settings)

    first = report.diagnoses[0]
    assert not first.consistent_with_noise
    assert first.ranking[0].name == "backlash" and first.ranking[0].significant
    assert report.effects_added == ["backlash"]
    assert all(name.startswith("stop(displacement") for name in report.iterations[0].features_added)
    assert report.error_after["nrmse"] < 0.7 * report.error_before["nrmse"]
    assert report.error_after["r2"] > report.error_before["r2"]
