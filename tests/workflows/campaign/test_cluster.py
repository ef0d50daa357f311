"""Campaigns on a real Dask cluster on localhost: a `dask scheduler` and two `dask worker` processes (started here,
stopped in teardown). The table equals the serial run's, a killed worker's cases finish elsewhere, and a campaign whose
`nnfmu batch` process is killed resumes from its parts."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from campaign_helpers import campaign_text, metrics_of, read_rows, write_campaign

from nnfmu.workflows.campaign import run_campaign

pytestmark = pytest.mark.slow

distributed = pytest.importorskip("distributed")
SCHEDULER = [sys.executable, "-m", "distributed.cli.dask_scheduler"]  # what `dask scheduler` runs
WORKER = [sys.executable, "-m", "distributed.cli.dask_worker"]  # what `dask worker` runs
START_TIMEOUT = 60.0  # [s] for the scheduler and workers to come up
RUN_TIMEOUT = 240.0  # [s] for a campaign on the cluster


def _environment(folder: Path) -> dict[str, str]:
    """The test's environment with a case retried once after its worker dies, as `nnfmu batch` documents, and the
    temporary files in `folder` (a killed worker cannot remove the FMUs it unpacked)."""
    return os.environ | {"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1", "TMPDIR": str(folder)}


def _wait(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"waited {timeout:g} s for {what}")
        time.sleep(0.05)


def _stop(process: subprocess.Popen) -> None:
    """Ask the process to end (a worker then closes its FMU instances), kill it if it has not within 30 s."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
    process.wait(timeout=30)


def _start_worker(address: str, name: str, folder: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [
            *WORKER,
            address,
            "--name",
            name,
            "--nthreads",
            "1",
            "--no-nanny",
            "--no-dashboard",
            "--local-directory",
            str(folder),
        ],
        env=_environment(folder),
        cwd=folder,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory):
    """(scheduler address, client) of a scheduler with two single-threaded workers, all subprocesses."""
    folder = tmp_path_factory.mktemp("dask")
    scheduler_file = folder / "scheduler.json"
    processes = [
        subprocess.Popen(
            [
                *SCHEDULER,
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--dashboard-address",
                "127.0.0.1:0",  # its HTTP server runs all the same: not on 8787, which the local clusters here take
                "--scheduler-file",
                str(scheduler_file),
            ],
            env=_environment(folder),
            cwd=folder,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    client = None
    try:
        _wait(lambda: scheduler_file.is_file() and scheduler_file.stat().st_size > 0, START_TIMEOUT, "the scheduler")
        address = json.loads(scheduler_file.read_text())["address"]
        processes += [_start_worker(address, f"worker-{i}", folder) for i in (1, 2)]
        client = distributed.Client(address, timeout=START_TIMEOUT)
        client.wait_for_workers(2, timeout=START_TIMEOUT)
        yield address, client, folder
    finally:
        if client is not None:
            client.close()
        for process in processes[::-1]:
            _stop(process)


@pytest.fixture(scope="module")
def serial(quarter_car, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list]:
    """The campaign file and its table's rows from a serial run (the reference for the cluster runs)."""
    folder = tmp_path_factory.mktemp("serial")
    path = write_campaign(folder, campaign_text(quarter_car, events=8, duration=2.0))
    run_campaign(path, folder / "out", workers=0)
    return path, read_rows(folder / "out")


def test_a_campaign_on_the_cluster_equals_the_serial_run(cluster, serial, tmp_path):
    address, _, _ = cluster
    path, rows = serial
    run = run_campaign(path, tmp_path / "out", scheduler=address)
    assert (run.engine.kind, run.engine.workers, run.engine.allowed_failures) == ("scheduler", 2, 1)
    assert (run.ok, run.failed) == (16, 0)
    assert metrics_of(read_rows(tmp_path / "out")) == metrics_of(rows)


def test_a_killed_workers_cases_finish_on_another(cluster, serial, tmp_path):
    """A third worker joins, gets cases, and is killed while it holds some: they run again elsewhere."""
    address, client, folder = cluster
    path, rows = serial
    victim = _start_worker(address, "victim", folder)
    try:
        client.wait_for_workers(3, timeout=START_TIMEOUT)
        victim_address = next(a for a, w in client.scheduler_info()["workers"].items() if w["name"] == "victim")
        outcome: dict[str, object] = {}
        runner = threading.Thread(
            target=lambda: outcome.update(run=run_campaign(path, tmp_path / "out", scheduler=address))
        )
        runner.start()
        held: list[str] = []

        def victim_busy() -> bool:
            held[:] = [k for k in client.processing().get(victim_address, ()) if "nnfmu-case" in str(k)]
            return bool(held)

        _wait(lambda: victim_busy() or not runner.is_alive(), RUN_TIMEOUT, "the victim worker to take a case")
        assert held, "the campaign finished before the victim worker took a case"
        victim.send_signal(signal.SIGKILL)
        runner.join(RUN_TIMEOUT)
        assert not runner.is_alive(), "the campaign did not finish after the worker was killed"
    finally:
        _stop(victim)
    run = outcome["run"]
    assert held and (run.ok, run.failed) == (16, 0)
    assert metrics_of(read_rows(tmp_path / "out")) == metrics_of(rows)


def test_a_killed_batch_command_resumes(cluster, serial, tmp_path):
    """`nnfmu batch --scheduler` killed after a few cases leaves whole parts and no table; run again, it skips them."""
    address, _, _ = cluster
    path, rows = serial
    out = tmp_path / "out"
    command = [sys.executable, "-m", "nnfmu.cli", "batch", str(path), "--out", str(out), "--scheduler", address]
    first = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        _wait(
            lambda: len(list((out / "parts").glob("*.parquet"))) >= 3 if (out / "parts").is_dir() else False,
            RUN_TIMEOUT,
            "three finished cases",
        )
        first.send_signal(signal.SIGKILL)
        first.wait(timeout=30)
    finally:
        _stop(first)
    done = len(list((out / "parts").glob("*.parquet")))
    assert not (out / "results.parquet").exists() or done == 16
    for part in (out / "parts").glob("*.parquet"):  # every part is whole (a killed write leaves only a .tmp file)
        assert pq.read_table(part).num_rows == 3
    second = subprocess.run(command, capture_output=True, text=True, timeout=RUN_TIMEOUT)
    assert second.returncode == 0, second.stderr
    assert f"16 cases: 16 ok, 0 failed, {done} finished before" in second.stdout
    assert metrics_of(read_rows(out)) == metrics_of(rows)


def test_the_default_engine_is_a_local_cluster_retrying_a_case_once(quarter_car, tmp_path):
    path = write_campaign(tmp_path, campaign_text(quarter_car, events=1))
    run = run_campaign(path, tmp_path / "out", workers=1)
    assert (run.engine.kind, run.engine.workers, run.engine.allowed_failures) == ("local", 1, 1)
    serial = run_campaign(path, tmp_path / "serial", workers=0)
    assert (run.ok, serial.ok) == (2, 2)
    assert metrics_of(read_rows(tmp_path / "out")) == metrics_of(read_rows(tmp_path / "serial"))
