"""The loop report's headline in an engineer's words (issue 31): what the model was missing, how much that explained,
the test error before -> after against the target; the diagnosis's test names only in the details section."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from nnfmu.data import Measurement
from nnfmu.diagnosis import Diagnosis
from nnfmu.diagnosis.evidence import EffectEvidence
from nnfmu.validate.verdict import Target
from nnfmu.workflows.loop.headline import headline
from nnfmu.workflows.loop.report import short_feature_name, write_loop_report
from nnfmu.workflows.loop.results import Iteration, LoopReport

DETAILS = (
    "added temperature, gas_force; final diagnosis: missing effect(s), in order of evidence: hysteresis (4.3% more of "
    "the residual variance)"
)


def evidence(name: str, extra: float) -> EffectEvidence:
    return EffectEvidence(1, name, "", True, extra, extra, 1e-6, True, 200.0, (), (), (), "")


def diagnosis(significant: tuple[EffectEvidence, ...], consistent: bool = False) -> Diagnosis:
    return Diagnosis("rig", "force", ("velocity",), 8000, 1e-3, 18.6, 0.1, (), significant, consistent, (), (), "")


def iteration(effects: tuple[str, ...], explained: float) -> Iteration:
    errors = {"nrmse": 0.02, "r2": 0.99, "peak_error": 0.01, "pseudo_damage_ratio": 1.0}
    return Iteration(
        effects,
        explained,
        explained,
        1e-8,
        "",
        "",
        (),
        errors,
        errors,
        0.03,
        0.02,
        True,
        Path("m.onnx"),
        Path("m.fmu"),
        0,
        "warm",
        {},
    )


def test_the_headline_says_what_was_missing_how_much_and_the_error_against_the_target():
    """The quick demo's loop: temperature and gas force added together, hysteresis still significant."""
    text = headline(
        "force",
        [iteration(("temperature", "gas_force"), 0.209)],
        diagnosis((evidence("hysteresis", 0.043),)),
        0.0286,
        0.0225,
        Target(),
    )
    assert text == (
        "The model was missing damping fade with oil temperature (temperature) and gas spring: preload and "
        "displacement dependence (gas_force) (20.9 % of the model's residual variance). Force NRMSE on the held-out "
        "test part 2.86 % → 2.25 % — within the 5 % target (default). Still missing after the loop: memory: "
        "compliance lag, force build-up after reversals (hysteresis), 4.3 % of what is left."
    )
    nothing = headline("force", [], diagnosis((), consistent=True), 0.011, 0.011, Target(0.01, "--target-nrmse"))
    assert nothing == (
        "Nothing was missing: the model's residual is consistent with noise. Force NRMSE on the held-out test part "
        "1.1 % — above the 1 % target (--target-nrmse)."
    )


def test_the_report_leads_with_the_headline_and_keeps_test_names_in_the_details(tmp_path):
    t = np.arange(4000) * 1e-3
    velocity = 0.3 * np.sin(2 * np.pi * 2.0 * t)
    m = Measurement(t, {"velocity": velocity, "force": 2000.0 * velocity}, {"velocity": "m/s", "force": "N"}, "rig")
    errors = {"nrmse": 0.0286, "r2": 0.99, "peak_error": 0.01, "pseudo_damage_ratio": 1.0}
    last = diagnosis((evidence("hysteresis", 0.043),))
    report = LoopReport(
        "rig",
        "m.onnx",
        "force",
        {},
        ["temperature", "gas_force"],
        [],
        errors,
        errors,
        Path("m.onnx"),
        Path("m.fmu"),
        False,
        "HEADLINE",
        [],
        [],
        [last],
        details=DETAILS,
        target={"nrmse": 0.05, "source": "default"},
    )
    rows = {"diagnosis": np.arange(0, 2000), "test": np.arange(2000, 4000)}
    write_loop_report(tmp_path, report, m, rows, 1.02 * m["force"] + 1.0, 1.01 * m["force"], [])
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert '<p class="verdict"><strong>HEADLINE</strong></p>' in html
    head, details = html.split("<h2>Details</h2>")
    assert "hysteresis (4.3% more" not in head and DETAILS in details
    document = json.loads((tmp_path / "report.json").read_text(encoding="utf-8"))
    assert document["summary"] == "HEADLINE" and document["details"] == DETAILS
    assert document["target"] == {"nrmse": 0.05, "source": "default"}


def test_the_report_tables_give_nrmse_in_per_cent_as_the_headline_does(tmp_path):
    """Issue 31: the before/after table printed 0.02858 under a headline of 2.86 %."""
    t = np.arange(4000) * 1e-3
    velocity = 0.3 * np.sin(2 * np.pi * 2.0 * t)
    m = Measurement(t, {"velocity": velocity, "force": 2000.0 * velocity}, {"velocity": "m/s", "force": "N"}, "rig")
    before = {"nrmse": 0.02858, "r2": 0.99, "peak_error": 0.01, "pseudo_damage_ratio": 1.0}
    after = {**before, "nrmse": 0.02251}
    kept = replace(iteration(("temperature",), 0.209), error_before=before, error_after=after)
    kept = replace(kept, diagnosis_nrmse_by_start={"warm": 0.0213, "fresh": 0.0247})
    report = LoopReport(
        "rig", "m.onnx", "force", {}, ["temperature"], [kept], before, after, Path("m.onnx"), Path("m.fmu"), False,
        "HEADLINE", [], [], [diagnosis(())], details=DETAILS, target={"nrmse": 0.05, "source": "default"},
    )  # fmt: skip
    rows = {"diagnosis": np.arange(0, 2000), "test": np.arange(2000, 4000)}
    write_loop_report(tmp_path, report, m, rows, 1.02 * m["force"] + 1.0, 1.01 * m["force"], [])
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    cells = re.findall(r"<t[dh]>([^<]*)</t[dh]>", html)
    assert "NRMSE [%]" in cells and "test NRMSE before [%]" in cells and "explained variance [%]" in cells
    assert cells.count("2.858") == 2 and cells.count("2.251") == 2 and "20.9" in cells
    assert "0.02858" not in html and "0.02251" not in html
    assert "warm 2.13, fresh 2.47" in html
    assert json.loads((tmp_path / "report.json").read_text(encoding="utf-8"))["error_before"]["nrmse"] == 0.02858


def test_a_fitted_parameter_in_a_feature_name_is_shortened_for_its_axis():
    """A fitted scale printed in full ran past the figure's edge; 3 significant digits fit, set values stay as given."""
    assert (
        short_feature_name("smooth_sign(velocity, scale=0.00502061833090149)") == "smooth_sign(velocity, scale=0.00502)"
    )
    assert short_feature_name("highpass(velocity, tau=0.001)") == "highpass(velocity, tau=0.001)"
    assert short_feature_name("stop(x, radius=1.2345678e-05)") == "stop(x, radius=1.23e-05)"
