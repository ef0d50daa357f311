"""`nnfmu batch`: read a campaign, run the cases not finished yet, assemble the table, the record and the summary.

Each finished case's part is written here as soon as it returns, so an interrupted run loses only the cases in
flight; the table, `campaign.json` and `summary.html` are written at the end from the parts of the campaign's cases.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Protocol

import nnfmu
from nnfmu.out_paths import OutputPathError, check_output_dir, mark_output_dir
from nnfmu.workflows.campaign.cases import Case, expand_cases
from nnfmu.workflows.campaign.engine import EngineInfo, dask_client, run_dask, run_serial
from nnfmu.workflows.campaign.errors import CampaignError
from nnfmu.workflows.campaign.execute import FAILED, CaseOutcome
from nnfmu.workflows.campaign.hashing import file_sha256
from nnfmu.workflows.campaign.record import inputs, write_record
from nnfmu.workflows.campaign.spec import read_campaign
from nnfmu.workflows.campaign.store import assemble, finished, write_part, write_table
from nnfmu.workflows.campaign.summary import write_summary


class Progress(Protocol):
    def start(self, total: int, skipped: int) -> None: ...

    def advance(self, outcome: CaseOutcome) -> None: ...

    def stop(self) -> None: ...


@dataclass(frozen=True)
class CampaignRun:
    """The outcome of `run_campaign`: file paths and counts (cases in all, skipped as finished before, ok, failed)."""

    table: Path
    summary: Path
    record: Path
    cases: int
    skipped: int
    ok: int
    failed: int
    wall_s: float
    engine: EngineInfo


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def run_campaign(
    campaign_file: str | Path,
    out: str | Path,
    scheduler: str | None = None,
    workers: int | None = None,
    retry_failed: bool = False,
    reuse_instances: bool = True,
    progress: Progress | None = None,
    warn: Callable[[str], None] = lambda _: None,
    allow_outside: bool = False,
) -> CampaignRun:
    """Run a campaign into `out`: on the Dask cluster at `scheduler`, else on a LocalCluster of `workers` processes
    (None: one per core), or here one case after another when `workers` is 0. Cases with a part in `out` are skipped
    (failed ones too, unless `retry_failed`). `reuse_instances`: FMU instances are reset between cases instead of
    opened again (the results are the same for FMUs whose reset works as FMI says). A part that fails verification
    (unreadable, another case's, changed since written) is passed to `warn` and its case run again. `allow_outside`:
    the campaign's files may lie outside its folder."""
    campaign = read_campaign(campaign_file, allow_outside)
    try:
        out = check_output_dir(out, "batch", [campaign_file])
    except OutputPathError as error:
        raise CampaignError(str(error)) from None
    out.mkdir(parents=True, exist_ok=True)
    mark_output_dir(out, "batch")
    cases = expand_cases(campaign)
    done = finished(out, cases, retry_failed, warn)
    todo = [case for case in cases if case.key not in done]
    given = inputs(campaign, cases)
    started, clock = _now(), time.perf_counter()
    write_record(out, given, {"started": started, "state": "running", "cases": len(cases), "skipped": len(done)}, None)
    channels = list(campaign.metrics.channels)

    def record(case: Case, outcome: CaseOutcome) -> None:
        write_part(out, outcome, channels)
        if progress is not None:
            progress.advance(outcome)

    if progress is not None:
        progress.start(len(cases), len(done))
    try:
        if not todo:
            engine = EngineInfo("none (every case finished before)", 0, 0, None, None)
        elif scheduler is None and workers == 0:
            engine = run_serial(todo, campaign.blobs, record, reuse_instances)
        else:
            with dask_client(scheduler, workers) as (client, engine):
                run_dask(client, todo, campaign.blobs, record, reuse_instances)
    finally:
        if progress is not None:
            progress.stop()
    table = assemble(out, cases, campaign.metrics.reference)
    table_path = write_table(out, table)
    failed = len(
        {
            key
            for key, status in zip(table.column("case").to_pylist(), table.column("status").to_pylist())
            if status == FAILED
        }
    )
    wall = time.perf_counter() - clock
    summary = write_summary(
        out,
        table,
        campaign.metrics.reference,
        {
            "name": campaign.name,
            "description": campaign.description,
            "cases": len(cases),
            "events": len(campaign.events),
            "variants": len(campaign.variants),
            "ok": len(cases) - failed,
            "failed": failed,
            "skipped": len(done),
            "wall_s": wall,
            "table": table_path.name,
            "engine": f"{engine.kind}, {engine.workers} worker(s), {engine.threads} thread(s)"
            + (f" at {engine.address}" if engine.address else ""),
            "slope": f"{campaign.metrics.basquin_slope:g}",
            "slopes": ", ".join(f"{k}: {v:g}" for k, v in campaign.metrics.slopes.items()),
            "version": nnfmu.__version__,
        },
    )
    run = {
        "started": started,
        "finished": _now(),
        "state": "finished",
        "wall_s": round(wall, 3),
        "cases": len(cases),
        "skipped": len(done),
        "ran": len(todo),
        "ok": len(cases) - failed,
        "failed": failed,
        "table": {"file": table_path.name, "sha256": file_sha256(table_path), "rows": table.num_rows},
        "summary": summary.name,
    }
    record_path = write_record(out, given, run, engine)
    return CampaignRun(
        table_path, summary, record_path, len(cases), len(done), len(cases) - failed, failed, wall, engine
    )
