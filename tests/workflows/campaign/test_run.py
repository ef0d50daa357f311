"""Campaign runs in this process: failing cases recorded with their message while the rest go on, scores checked
against their definitions, parts written atomically, an interrupted campaign resumed, files in the output folder."""

from __future__ import annotations

import json
import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import rainflow
from campaign_helpers import campaign_text, metrics_of, read_rows, write_campaign

from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import open_system
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.campaign import run_campaign
from nnfmu.workflows.campaign.execute import CaseOutcome

BAD_DRIVE = '[[events]]\nname = "bad-file"\ndrive = "bad.csv"'


class StopAfter:
    """A progress sink that interrupts the run (as Ctrl-C would) after `count` cases."""

    def __init__(self, count: int) -> None:
        self.count = count

    def start(self, total: int, skipped: int) -> None:
        pass

    def advance(self, outcome: CaseOutcome) -> None:
        self.count -= 1
        if self.count == 0:
            raise KeyboardInterrupt

    def stop(self) -> None:
        pass


def test_failing_cases_are_recorded_and_the_rest_go_on(quarter_car, tmp_path):
    (tmp_path / "bad.csv").write_text("time [s],actuator_fl_displacement [m]\n0,0\n0.001,zz\n")
    text = campaign_text(quarter_car, events=2, variants=("linear", "unstable", "firm"), extra_events=BAD_DRIVE)
    run = run_campaign(write_campaign(tmp_path, text), tmp_path / "out", workers=0)
    assert (run.cases, run.failed, run.ok) == (9, 5, 4)  # unstable x 3 events, bad-file x the other 2 variants
    rows = read_rows(tmp_path / "out")
    failed = {(r["event"], r["variant"]): r["error"] for r in rows if r["status"] == "failed"}
    assert set(failed) == {(e, "unstable") for e in ("C-20#0", "C-20#1", "bad-file")} | {
        ("bad-file", "linear"),
        ("bad-file", "firm"),
    }
    assert failed[("C-20#0", "unstable")].startswith("CosimError: system 'quarter car', step from t = ")
    assert (
        "the coupling diverged: damper (damper-unstable.fmu) output force went from" in failed[("C-20#0", "unstable")]
    )
    assert failed[("bad-file", "linear")] == (
        "DataError: bad.csv: line 3, column 'actuator_fl_displacement [m]': 'zz' is not a number"
    )
    ok = [r for r in rows if r["status"] == "ok"]
    assert len(ok) == 4 * 3 and all(math.isfinite(r["damage"]) and r["error"] == "" for r in ok)
    assert all(math.isnan(r["damage"]) and math.isnan(r["damage_ratio"]) for r in rows if r["status"] == "failed")
    record = json.loads((tmp_path / "out" / "campaign.json").read_text())
    assert record["run"]["failed"] == 5 and record["run"]["state"] == "finished"
    summary = (tmp_path / "out" / "summary.html").read_text()
    assert "Failed cases (5)" in summary and "bad.csv" in summary


def test_scores_match_their_definitions(quarter_car, tmp_path):
    """One case's row against a co-simulation run here and scored with numpy and rainflow directly."""
    run_campaign(write_campaign(tmp_path, campaign_text(quarter_car, events=1)), tmp_path / "out", workers=0)
    rows = {(r["variant"], r["channel"]): r for r in read_rows(tmp_path / "out")}
    drive = generate_drive(DriveSettings(road_class="C", speed=20.0, duration=1.0, seed=0))
    with open_system(quarter_car["system"]) as system:  # the base system holds the linear damper
        result = cosimulate(system, drive, CosimSettings(step=1e-3)).measurement
    for channel, slope in (("damper_force", 5.0), ("damper_displacement", 3.0)):
        row, x = rows[("linear", channel)], result[channel]
        assert row["unit"] == result.units[channel]
        assert row["rms"] == pytest.approx(np.sqrt(np.mean(x**2)), rel=1e-12)
        assert (row["peak"], row["valley"]) == (x.max(), x.min())
        damage = sum(n * r**slope for r, n in rainflow.count_cycles(x))
        assert row["damage"] == pytest.approx(damage, rel=1e-12) and row["basquin_slope"] == slope
        assert row["damage_ratio"] == 1.0
        firm = rows[("firm", channel)]
        assert firm["damage_ratio"] == pytest.approx(firm["damage"] / row["damage"], rel=1e-12)
    assert rows[("firm", "damper_force")]["damage_ratio"] > 1.0  # a firmer damper carries larger forces


@pytest.mark.slow
def test_an_interrupted_campaign_resumes_from_its_parts(quarter_car, tmp_path):
    path = write_campaign(tmp_path, campaign_text(quarter_car, events=3))
    whole = run_campaign(path, tmp_path / "whole", workers=0)
    with pytest.raises(KeyboardInterrupt):
        run_campaign(path, tmp_path / "out", workers=0, progress=StopAfter(2))
    parts = sorted((tmp_path / "out" / "parts").iterdir())
    assert len(parts) == 2 and all(p.suffix == ".parquet" for p in parts)  # no temporary file left behind
    assert not (tmp_path / "out" / "results.parquet").exists()
    assert json.loads((tmp_path / "out" / "campaign.json").read_text())["run"]["state"] == "running"
    before = {p.name: p.stat().st_mtime_ns for p in parts}
    resumed = run_campaign(path, tmp_path / "out", workers=0)
    assert (resumed.skipped, resumed.ok, whole.ok) == (2, 6, 6)
    assert {p.name: p.stat().st_mtime_ns for p in parts} == before  # finished parts were not rewritten
    assert metrics_of(read_rows(tmp_path / "out")) == metrics_of(read_rows(tmp_path / "whole"))
    again = run_campaign(path, tmp_path / "out", workers=0)
    assert again.skipped == 6 and again.engine.workers == 0


@pytest.mark.slow
def test_a_resumed_campaign_runs_again_the_cases_whose_part_is_truncated_swapped_or_changed(quarter_car, tmp_path):
    """A truncated part was a traceback that blocked resuming; a part copied over another case's, or with a row
    duplicated, was merged (duplicate rows, exit 0). Each is named in a warning and its case runs again."""
    path = write_campaign(tmp_path, campaign_text(quarter_car, events=2))
    run_campaign(path, tmp_path / "out", workers=0)
    expected = metrics_of(read_rows(tmp_path / "out"))
    parts = sorted((tmp_path / "out" / "parts").iterdir())
    assert len(parts) == 4
    truncated, swapped, doubled, kept = parts
    truncated.write_bytes(truncated.read_bytes()[:100])
    swapped.write_bytes(kept.read_bytes())
    table = pq.read_table(doubled)
    pq.write_table(pa.concat_tables([table, table.slice(0, 1)]), doubled)  # metadata kept, a row more
    warnings: list[str] = []
    resumed = run_campaign(path, tmp_path / "out", workers=0, warn=warnings.append)
    assert (resumed.skipped, resumed.ok) == (1, 4)  # three run again, every case ok
    assert len(warnings) == 3, warnings
    for part, words in ((truncated, "cannot read"), (swapped, "does not name case"), (doubled, "checksum")):
        assert any(str(part) in w and words in w for w in warnings), warnings
    rows = pq.read_table(tmp_path / "out" / "results.parquet")
    assert rows.num_rows == len(set(zip(rows.column("case").to_pylist(), rows.column("channel").to_pylist())))
    assert metrics_of(read_rows(tmp_path / "out")) == expected


@pytest.mark.slow
def test_changed_inputs_rerun_only_their_cases_and_failed_cases_rerun_on_request(quarter_car, tmp_path):
    path = write_campaign(tmp_path, campaign_text(quarter_car, events=2, variants=("linear", "unstable")))
    first = run_campaign(path, tmp_path / "out", workers=0)
    assert (first.ok, first.failed) == (2, 2)
    write_campaign(tmp_path, campaign_text(quarter_car, events=2, variants=("linear", "unstable", "firm")))
    grown = run_campaign(path, tmp_path / "out", workers=0)
    assert (grown.skipped, grown.ok, grown.failed) == (4, 4, 2)
    retried = run_campaign(path, tmp_path / "out", workers=0, retry_failed=True)
    assert (retried.skipped, retried.failed) == (4, 2)
    table = pq.read_table(tmp_path / "out" / "results.parquet")
    assert table.num_rows == 6 * 3 and set(table.column("variant").to_pylist()) == {"linear", "unstable", "firm"}


@pytest.mark.slow
def test_hostile_names_are_shown_as_they_are(quarter_car, tmp_path):
    """Names with markup and math characters reach the table unchanged and the summary escaped."""
    text = campaign_text(quarter_car, events=1).replace('name = "C-20"', 'name = "$x^{2}$ <b>pot</b>"')
    text = text.replace('name = "firm"', 'name = "fi$rm & <i>"')
    run = run_campaign(write_campaign(tmp_path, text), tmp_path / "out", workers=0)
    assert run.ok == 2
    rows = read_rows(tmp_path / "out")
    assert {r["event"] for r in rows} == {"$x^{2}$ <b>pot</b>"} and "fi$rm & <i>" in {r["variant"] for r in rows}
    summary = (tmp_path / "out" / "summary.html").read_text()
    assert "<b>pot</b>" not in summary and "&lt;b&gt;pot&lt;/b&gt;" in summary
    assert (tmp_path / "out" / "worst_events.png").stat().st_size > 0


def test_the_batch_command_names_a_bad_key_and_exits_non_zero(quarter_car, tmp_path):
    from typer.testing import CliRunner

    from nnfmu.cli import app

    text = campaign_text(quarter_car).replace("[coupling]\n", "[coupling]\nstep_size = 1e-3\n")
    result = CliRunner().invoke(app, ["batch", str(write_campaign(tmp_path, text)), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "error:" in result.output and "step_size" in result.output
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("address", ["not a url", "tcp://", "bogus://host:8786"])
def test_a_scheduler_address_that_is_not_one_is_one_error_line(quarter_car, tmp_path, address):
    from typer.testing import CliRunner

    from nnfmu.cli import app

    path = write_campaign(tmp_path, campaign_text(quarter_car))
    result = CliRunner().invoke(app, ["batch", str(path), "--out", str(tmp_path / "out"), "--scheduler", address])
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    last = result.output.strip().splitlines()[-1]
    assert last.startswith("error: ") and repr(address) in last, result.output


def test_the_batch_command_refuses_a_folder_it_did_not_write(quarter_car, tmp_path):
    from typer.testing import CliRunner

    from nnfmu.cli import app

    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "summary.html").write_text("someone's page")
    result = CliRunner().invoke(
        app, ["batch", str(write_campaign(tmp_path, campaign_text(quarter_car, events=1))), "--out", str(foreign)]
    )
    assert result.exit_code == 2, result.output
    assert "error:" in result.output and "not empty" in result.output and str(foreign) in result.output
    assert [p.name for p in foreign.iterdir()] == ["summary.html"]
    assert (foreign / "summary.html").read_text() == "someone's page"


@pytest.mark.slow
def test_reused_instances_give_the_results_of_fresh_ones(quarter_car, tmp_path):
    """Cases run on reset FMU instances score exactly as on freshly opened ones, failed cases among them (whose
    instances are closed, not kept)."""
    text = campaign_text(quarter_car, events=2, variants=("linear", "unstable", "firm"))
    path = write_campaign(tmp_path, text)
    reused = run_campaign(path, tmp_path / "reused", workers=0)
    fresh = run_campaign(path, tmp_path / "fresh", workers=0, reuse_instances=False)
    assert (reused.ok, reused.failed) == (fresh.ok, fresh.failed) == (4, 2)
    assert metrics_of(read_rows(tmp_path / "reused")) == metrics_of(read_rows(tmp_path / "fresh"))
