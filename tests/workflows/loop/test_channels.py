"""`run_loop` with a measured channel the first model does not use: on a magnetorheological damper record the loop
adds the coil voltage (`input:voltage`, the channel and its low-passes) to a velocity-only network and the held-out
error falls; on a passive damper record with an unrelated random voltage beside it, the voltage is never significant
and the loop adds nothing for it (bench/loop_channels.py measures the MR and CDC records at full length)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nnfmu.data import Measurement
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.export import export_onnx
from nnfmu.models import Architecture, TrainSettings, get_preset, train_model
from nnfmu.workflows.loop import LoopSettings, run_loop, training_part

SPEC = get_preset("damper-hysteresis").spec  # velocity, its differences, the friction sign: no command
SETTINGS = LoopSettings(max_effects=1, max_epochs=60, extra_hidden=(0, 4), lm_max_samples=4000)
VELOCITY_HISTORY = ("hysteresis", "seal_friction", "inertia")  # every passive effect SPEC represents


def record(damper_type: str) -> Measurement:
    """A 20 s random-drive record; the passive one (only effects SPEC represents) gets a random 0-5 V voltage in
    steps of 0.1 s that does nothing to the force."""
    effects = None if damper_type == "mr" else VELOCITY_HISTORY
    m = simulate_rig(
        "damper",
        RigOptions(duration=20.0, seed=1, damper_type=damper_type, excitation="random", noise=0.5, effects=effects),
    ).measurement
    if damper_type == "mr":
        return m
    steps = np.random.default_rng(5).uniform(0.0, 5.0, len(m) // 100 + 1)
    return Measurement(
        m.time,
        {**m.channels, "voltage": np.repeat(steps, 100)[: len(m)]},
        {**m.units, "voltage": "V"},
        f"{m.source} (unrelated voltage)",
    )


def first_model(m: Measurement, folder: Path) -> Path:
    """A small velocity-history network fitted on the loop's training blocks only."""
    model = train_model(
        training_part(m, SETTINGS), SPEC, Architecture("mlp", (6,)), TrainSettings(max_epochs=100, restarts=1)
    ).model
    path = folder / "first.onnx"
    export_onnx(model, path)
    return path


@pytest.mark.slow
def test_the_loop_adds_the_command_of_an_mr_damper_and_says_so(tmp_path):
    m = record("mr")
    out = tmp_path / "loop"
    report = run_loop(m, first_model(m, tmp_path), "force", out, SETTINGS)
    assert report.effects_added[0] == "input:voltage"  # a second significant effect may join it (trials.py)
    assert report.error_after["nrmse"] < 0.5 * report.error_before["nrmse"]
    document = json.loads((out / "report.json").read_text())
    step = document["iterations"][0]
    assert "voltage[k]" in step["features_added"]
    assert any(name.startswith("lowpass(voltage") for name in step["features_added"])
    assert "measured channel voltage [V] as a model input" in step["extension"] and "low-passes" in step["extension"]
    assert "input:voltage" in (out / "report.html").read_text()


@pytest.mark.slow
def test_an_unrelated_channel_is_never_added(tmp_path):
    m = record("passive")
    out = tmp_path / "loop"
    report = run_loop(m, first_model(m, tmp_path), "force", out, SETTINGS)
    assert "input:voltage" not in report.effects_added
    for d in report.diagnoses:
        (voltage,) = [e for e in d.ranking if e.name == "input:voltage"]
        assert voltage.testable and not voltage.significant
    assert Path(json.loads((out / "report.json").read_text())["fmu"]).is_file()
