"""The loop on measured data: the BRFD friction damper with backlash (tests/data/brfd, CC BY-SA 4.0, Coble et al.
2022), from a velocity-only network. The residual is not noise, the effect library's backlash family (stop operators
of displacement) explains it, and its features lower the held-out error. (The backlash effect's own halves:
tests/diagnosis/test_backlash.py.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nnfmu.data.importers import load_brfd_series
from nnfmu.diagnosis import EFFECTS, DiagnosisSettings
from nnfmu.export import export_onnx
from nnfmu.models import Architecture, TrainSettings, train_model
from nnfmu.models.features import FeatureSpec, SmoothSign, Tap
from nnfmu.workflows.loop import LoopSettings, part_measurement, plan_blocks, run_loop

pytestmark = pytest.mark.slow

SLICE = Path(__file__).parents[2] / "data" / "brfd"
RUNS = [SLICE / f"1Hz36lbtension{a}amplitude.json.gz" for a in ("0.5", "1", "1.5")]
# The damper has no gas spring: the diagnosis ranks the other families (as examples/brfd_loop.py --effects does).
EFFECTS_RANKED = tuple(name for name in EFFECTS if name != "gas_force")
# Velocity-only start: force from velocity and its friction sign. (The damper-hysteresis preset's velocity differences
# count samples; at the slice's 256 Hz they span 4x the time they were chosen for at 1 kHz.)
VELOCITY_ONLY = FeatureSpec((Tap("velocity"),), "force", (SmoothSign("velocity", scale=0.01),))


def test_the_loop_finds_backlash_in_the_measured_damper_and_the_held_out_error_falls(tmp_path):
    m = load_brfd_series(RUNS)  # three 1 Hz runs at 36 lb band tension, 256 Hz, 21 s
    settings = LoopSettings(
        max_effects=1,
        segments=2 * len(RUNS),
        max_epochs=60,
        extra_hidden=(0, 4),
        lm_max_samples=3000,
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
    # the stop family reads as play, not as a seal's pre-sliding stiffness: a dead zone after each reversal
    assert first.stop_reading.effect == "backlash" and first.stop_reading.index > 1.0
    assert report.effects_added == ["backlash"]
    assert all(name.startswith("stop(displacement") for name in report.iterations[0].features_added)
    assert report.error_after["nrmse"] < 0.7 * report.error_before["nrmse"]
    assert report.error_after["r2"] > report.error_before["r2"]
