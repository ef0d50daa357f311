"""The loop's report links the characterisation of its model (`LoopSettings.characterise`): the link is relative,
resolves to the report written inside the loop's folder."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.export import export_onnx
from nnfmu.models import Architecture, TrainSettings, get_preset, train_model
from nnfmu.workflows.characterise.settings import QUICK_SETTINGS
from nnfmu.workflows.loop import LoopSettings, run_loop

# No effect is added (max_effects 0): the loop replays, diagnoses once and reports, so the test stays short.
SETTINGS = LoopSettings(max_effects=0, characterise=QUICK_SETTINGS)


@pytest.mark.slow
def test_the_loop_report_links_the_models_characterisation(tmp_path: Path) -> None:
    m = simulate_rig("damper", RigOptions(duration=8.0, excitation="random", noise=0.5)).measurement
    trained = train_model(
        m, get_preset("damper-hysteresis").spec, Architecture("mlp", (3,)), TrainSettings(max_epochs=3, restarts=1)
    )
    model = tmp_path / "damper.onnx"
    export_onnx(trained.model, model)
    report = run_loop(m, model, "force", tmp_path / "loop", SETTINGS)
    assert report.characterisations == {"first": {"link": "characterise/first/index.html", "reason": ""}}
    html = (tmp_path / "loop" / "report.html").read_text(encoding="utf-8")
    assert '<a href="characterise/first/index.html">first model\'s characterisation</a>' in html
    assert (tmp_path / "loop" / "characterise" / "first" / "index.html").is_file()
    assert (tmp_path / "loop" / "characterise" / "first" / "characteristic.csv").is_file()
    document = json.loads((tmp_path / "loop" / "report.json").read_text(encoding="utf-8"))
    assert document["characterisations"]["first"]["link"] == "characterise/first/index.html"
