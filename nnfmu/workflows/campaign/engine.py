"""Where cases run: in this process one after another, or on Dask (a LocalCluster of worker processes, or an existing
cluster by its scheduler address).

On Dask, a task is a group of consecutive cases (events outer, variants inner: a group shares drives and FMUs),
sized so that each worker thread still gets several groups. A short case (a 10 s quarter-car drive runs in ~20 ms)
costs the engine about as much as it costs to run, so one task per case would halve the throughput; and a worker
keeps its FMU instances between the cases of all its groups, resetting them instead of opening them again. The files
a group needs travel with its task as bytes (an FMU is some tens of kB), so workers need the same nnfmu install but no
shared folder, and a task a dead worker held carries everything it needs to run elsewhere (data scattered to one
worker would die with it). Groups are sent a window at a time (a few per worker thread, topped up as they finish),
so the bytes in flight stay bounded. Robustness is Dask's own: a worker that dies takes its tasks back to the
scheduler, which runs them elsewhere until `allowed-failures` deaths (set to 1 for the LocalCluster: a case is
retried once), then reports KilledWorker, which is recorded as the failure of the group's cases; `retries=1` reruns
a task that raised outside the cases' own error handling. A lost scheduler, or a cluster left without any worker for
WAIT_FOR_WORKERS seconds, stops the run with a CampaignError (nothing is recorded as failed for it), and a rerun
resumes from the parts written.
"""

from __future__ import annotations

import logging
import math
import time
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nnfmu.models.cores import usable_cores
from nnfmu.workflows.campaign.cases import Case
from nnfmu.workflows.campaign.errors import CampaignError
from nnfmu.workflows.campaign.execute import FAILED, CaseOutcome, release_instances, run_case, run_cases
from nnfmu.workflows.campaign.hashing import file_bytes

ALLOWED_FAILURES = 1  # worker deaths a case may be involved in before it is given up (LocalCluster)
LOCAL_CONFIG = {
    "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
    # the statistical profiler keeps an hour of per-second stack trees in each worker: tens of MB over a campaign
    "distributed.worker.profile.enabled": False,
}
GROUPS_PER_THREAD = 4  # groups per worker thread over the whole run (balance), also the groups in flight per thread
MAX_GROUP = 16  # cases in one task at most
WAIT_FOR_WORKERS = 60  # seconds to wait for a cluster without workers to get one (at the start or during a run)
POLL = 0.1  # [s] between looks for a finished group while none is ready
OnOutcome = Callable[[Case, CaseOutcome], None]


@dataclass(frozen=True)
class EngineInfo:
    """How a run was executed: 'serial', 'local' (LocalCluster) or 'scheduler'; workers and threads in all; the
    scheduler's address and its allowed failures per task (None when serial)."""

    kind: str
    workers: int
    threads: int
    address: str | None
    allowed_failures: int | None


class FileBytes(Mapping[str, bytes]):
    """A campaign's blobs as bytes: FMUs are held in memory already, drive files are read when asked for."""

    def __init__(self, blobs: Mapping[str, bytes | Path]) -> None:
        self._blobs = blobs

    def __getitem__(self, key: str) -> bytes:
        value = self._blobs[key]
        return file_bytes(value) if isinstance(value, Path) else value

    def __iter__(self) -> Iterator[str]:
        return iter(self._blobs)

    def __len__(self) -> int:
        return len(self._blobs)


def run_serial(
    cases: Sequence[Case], blobs: Mapping[str, bytes | Path], on_outcome: OnOutcome, reuse_instances: bool = True
) -> EngineInfo:
    """Run the cases here, one after another (the reference the distributed runs are checked against)."""
    files = FileBytes(blobs)
    try:
        for case in cases:
            on_outcome(case, run_case(case, files, reuse_instances))
    finally:
        release_instances()
    return EngineInfo("serial", 1, 1, None, None)


def group_cases(cases: Sequence[Case], threads: int) -> list[list[Case]]:
    """Consecutive cases in groups of equal size: GROUPS_PER_THREAD groups per thread, at most MAX_GROUP cases each."""
    size = max(1, min(MAX_GROUP, math.ceil(len(cases) / (GROUPS_PER_THREAD * max(1, threads)))))
    return [list(cases[i : i + size]) for i in range(0, len(cases), size)]


def _installed() -> dict[str, str]:
    """nnfmu's and fmpy's versions where this runs (compared between the client and each worker)."""
    import fmpy

    import nnfmu

    return {"nnfmu": nnfmu.__version__, "fmpy": fmpy.__version__}


def check_workers(client: Any) -> None:
    """Every worker runs the same nnfmu and fmpy as this process; CampaignError names the first that does not."""
    here = _installed()
    for worker, versions in client.run(_installed).items():
        if versions != here:
            raise CampaignError(
                f"Dask worker {worker} has {versions}, this process {here}: workers need the same nnfmu install"
            )


def run_dask(
    client: Any,
    cases: Sequence[Case],
    blobs: Mapping[str, bytes | Path],
    on_outcome: OnOutcome,
    reuse_instances: bool = True,
) -> None:
    """Run the cases on the client's cluster in groups, calling `on_outcome` here for each case as its group finishes
    (groups in finishing order)."""
    from distributed import as_completed

    files = FileBytes(blobs)
    threads = max(1, sum(client.nthreads().values()))
    window = max(2, GROUPS_PER_THREAD * threads)
    run = uuid.uuid4().hex[:8]
    queue = iter(group_cases(cases, threads))
    running: dict[Any, list[Case]] = {}
    finished = as_completed()

    def submit_next() -> None:
        group = next(queue, None)
        if group is None:
            return
        keys = dict.fromkeys(key for case in group for key in case.blob_keys)
        future = client.submit(
            run_cases,
            group,
            {key: files[key] for key in keys},
            reuse_instances,
            key=f"nnfmu-cases-{group[0].key[:16]}-{run}",
            pure=False,
            retries=1,
        )
        running[future] = group
        finished.add(future)

    for _ in range(window):
        submit_next()
    workerless_since = None
    while running:
        if not finished.has_ready():
            if client.nthreads():
                workerless_since = None
            elif workerless_since is None:
                workerless_since = time.monotonic()
            elif time.monotonic() - workerless_since > WAIT_FOR_WORKERS:
                first = next(iter(running.values()))[0]
                raise CampaignError(
                    f"the Dask cluster has had no workers for {WAIT_FOR_WORKERS:g} s with "
                    f"{sum(len(g) for g in running.values())} case(s) sent and unfinished (the first "
                    f"{first.event.name} x {first.variant.name}); start a worker, then run the campaign again to "
                    f"resume from the parts written"
                )
            time.sleep(POLL)
            continue
        future = next(finished)
        group = running.pop(future)
        if future.status == "error":
            error = future.exception()
            outcomes = [
                CaseOutcome(
                    case.key, case.event.name, case.variant.name, FAILED, f"{type(error).__name__}: {error}", math.nan
                )
                for case in group
            ]
        elif future.status == "finished":
            outcomes = future.result()
        else:
            raise CampaignError(
                f"the Dask cluster lost {len(group)} case(s), the first {group[0].event.name} x "
                f"{group[0].variant.name} ({future.status}); run the campaign again to resume"
            )
        future.release()
        for case, outcome in zip(group, outcomes):
            on_outcome(case, outcome)
        submit_next()


@contextmanager
def dask_client(scheduler: str | None, workers: int | None) -> Iterator[tuple[Any, EngineInfo]]:
    """A client of the cluster at `scheduler`, or of a new LocalCluster of `workers` single-threaded processes
    (default: one per core), closed afterwards."""
    import dask
    from distributed import Client, LocalCluster

    cluster = None
    try:
        if scheduler is None:
            with dask.config.set(LOCAL_CONFIG):
                cluster = LocalCluster(
                    n_workers=workers or usable_cores(),  # one worker process per core this process may run on
                    threads_per_worker=1,
                    processes=True,
                    # the scheduler's HTTP server (status, metrics) starts even without a dashboard: on a free port of
                    # this machine alone, not on every interface's 8787, which another cluster may hold
                    dashboard_address="127.0.0.1:0",
                    silence_logs=logging.ERROR,
                )
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler, timeout="30s")
            except ValueError as error:  # distributed's address parsing: no scheme or port, an unknown protocol
                raise CampaignError(
                    f"--scheduler {scheduler!r} is not a Dask scheduler address (e.g. tcp://HOST:8786): {error}"
                ) from None
            except (OSError, TimeoutError) as error:
                raise CampaignError(f"cannot reach the Dask scheduler at {scheduler}: {error}") from None
        try:
            if not client.nthreads():
                try:
                    client.wait_for_workers(1, timeout=WAIT_FOR_WORKERS)
                except TimeoutError:
                    raise CampaignError(
                        f"the Dask scheduler at {scheduler} has no workers (waited {WAIT_FOR_WORKERS} s)"
                    ) from None
            check_workers(client)
            nthreads = client.nthreads()
            info = EngineInfo(
                "local" if cluster is not None else "scheduler",
                len(nthreads),
                sum(nthreads.values()),
                client.scheduler.address,
                client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.allowed_failures),
            )
            yield client, info
        finally:
            client.close()
    finally:
        if cluster is not None:
            cluster.close()
