"""Every report carries one verdict line against the target it was run for, saying where the target comes from
(issue 31): the validation report, the road test's system report and the campaign summary."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa
import pytest

from nnfmu.data.measurement import Measurement
from nnfmu.validate import ValidationError, compare
from nnfmu.validate.report import write_report
from nnfmu.validate.verdict import DEFAULT_TARGET_NRMSE, Target, verdict
from nnfmu.workflows.campaign.store import TABLE_SCHEMA
from nnfmu.workflows.campaign.summary import write_summary
from nnfmu.workflows.roadtest.report import write_system_report
from nnfmu.workflows.roadtest.thesis import model_verdicts, thesis_row

T = np.arange(0.0, 8.0, 1e-3)
FORCE = 1000.0 * np.sin(2 * np.pi * 1.3 * T) + 200.0 * np.sin(2 * np.pi * 9.0 * T)


def measurement(**channels: np.ndarray) -> Measurement:
    return Measurement(time=T, channels=channels, units={k: "N" for k in channels}, source="run")


def test_the_verdict_line_names_error_target_and_source():
    assert verdict("damper force", 0.018, Target()) == "damper force NRMSE 1.8 % — within the 5 % target (default)"
    assert verdict("force", 0.075, Target(0.05, "--target-nrmse")) == (
        "force NRMSE 7.5 % — above the 5 % target (--target-nrmse)"
    )
    assert "2.86 % → 2.25 %" in verdict("force", 0.0225, Target(), before=0.0286)
    assert "no verdict" in verdict("flat", float("nan"), Target())
    assert DEFAULT_TARGET_NRMSE == 0.05
    with pytest.raises(ValidationError, match="target NRMSE"):
        Target(-0.1)


@pytest.mark.slow
def test_the_validation_report_has_a_verdict_in_html_and_json(tmp_path):
    reference = measurement(damper_force=FORCE, spring_force=FORCE)
    result = measurement(damper_force=FORCE * 1.01, spring_force=FORCE * 1.09)
    comparisons = compare(result, reference, ["damper_force", "spring_force"])
    index = write_report(comparisons, tmp_path / "default", "run")
    line = "worst channel spring_force [N] NRMSE 9 % — above the 5 % target (default); 1 of 2 channels within"
    assert f'<p class="verdict"><strong>{line}</strong></p>' in index.read_text(encoding="utf-8")
    summary = json.loads((index.parent / "summary.json").read_text(encoding="utf-8"))
    assert summary["verdict"] == line and summary["target"] == {"nrmse": 0.05, "source": "default"}
    index = write_report(comparisons, tmp_path / "option", "run", target=Target(0.10, "--target-nrmse"))
    assert "within the 10 % target (--target-nrmse); 2 of 2 channels within" in index.read_text(encoding="utf-8")


def test_the_road_test_report_has_a_verdict_per_damper_model(tmp_path):
    reference = measurement(damper_fl_force=FORCE, lca_fl_force=FORCE)
    rows = []
    for model, gain in (("damper-spline", 1.08), ("damper-hysteresis", 1.02)):
        result = measurement(damper_fl_force=gain * FORCE, lca_fl_force=FORCE)
        rows += [thesis_row(c, model) for c in compare(result, reference, ["damper_fl_force", "lca_fl_force"])]
    lines = model_verdicts(rows, Target())
    assert lines == [
        "damper-spline: worst channel damper_fl_force [N] NRMSE 8 % — above the 5 % target (default)",
        "damper-hysteresis: worst channel damper_fl_force [N] NRMSE 2 % — within the 5 % target (default)",
    ]
    summary = {
        "system": "full-vehicle",
        "verdicts": lines,
        "thesis_table": [r.to_dict() for r in rows],
        "budget": [],
        "envelope": [],
        "seconds": {},
        "ssds": {},
    }
    html = write_system_report(summary, {}, {}, tmp_path / "index.html").read_text(encoding="utf-8")
    assert all(f'<p class="verdict"><strong>{line}</strong></p>' in html for line in lines)


def test_the_campaign_summary_has_a_verdict_against_its_reference_variant(tmp_path):
    row = dict.fromkeys(TABLE_SCHEMA.names, 0.0) | {"unit": "N", "channel": "damper_fl_force", "status": "ok"}
    rows = [
        row | {"case": f"{e}-{v}", "event": e, "variant": v, "damage": d, "error": ""}
        for e, v, d in (
            ("pothole", "base", 2.0),
            ("pothole", "stiff", 2.5),
            ("rough", "base", 1.0),
            ("rough", "stiff", 1.3),
        )
    ]
    table = pa.Table.from_pylist(rows, schema=TABLE_SCHEMA)
    path = write_summary(
        tmp_path,
        table,
        "base",
        {
            "name": "c",
            "description": "",
            "cases": 4,
            "events": 2,
            "variants": 2,
            "ok": 4,
            "failed": 0,
            "skipped": 0,
            "engine": "local",
            "wall_s": 1.0,
            "slope": 5.0,
            "slopes": "",
            "table": "t",
            "version": "0",
        },
    )
    html = path.read_text(encoding="utf-8")
    line = (
        "worst: stiff on damper_fl_force [N], programme damage ratio 1.27 — 27% more damage than the reference "
        "variant base (the campaign&#39;s reference, ratio 1)"
    )
    assert f'<p class="verdict"><strong>{line}</strong></p>' in html, html[:2000]


def test_nnfmu_validate_prints_the_verdict_and_takes_the_target_as_an_option(tmp_path):
    from typer.testing import CliRunner

    from nnfmu.cli import app
    from nnfmu.data.save import save_measurement

    reference = save_measurement(measurement(damper_force=FORCE), tmp_path / "reference.csv")
    result = save_measurement(measurement(damper_force=1.03 * FORCE), tmp_path / "result.csv")
    run = CliRunner().invoke(
        app, ["validate", str(result), str(reference), "--out", str(tmp_path / "r"), "--target-nrmse", "2"]
    )
    assert run.exit_code == 0, run.output
    assert "verdict: damper_force [N] NRMSE 3 % — above the 2 % target (--target-nrmse); 0 of 1 channel within" in (
        run.output
    )
    assert "damper_force [N]: NRMSE 3 %, R2" in run.output  # per cent as the verdict, not 0.03 (issue 31)
    html = (tmp_path / "r" / "index.html").read_text(encoding="utf-8")
    assert "<th>NRMSE [%]</th>" in html and "<td>N</td>\n<td>3</td><td>" in html  # after the unit: 3 %, not 0.03
