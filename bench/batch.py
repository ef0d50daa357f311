"""Campaign throughput on Dask: cases per hour serial vs a LocalCluster of 2 workers (parallel efficiency; target
>= 85 %), the engine's overhead per case (1-worker LocalCluster vs serial), and one worker's RSS and open files after
1000 quarter-car cases vs after 10 (target: growth <= 10 %), beside the same for this process running them serially.
Also the FMU set-up cost per case that reusing instances saves (open vs fmi2Reset), and the serial rate with
instances opened afresh for every case. JSON lines, the summary last.

Usage: python bench/batch.py [--cases 400] [--duration 10] [--rounds 5] [--memory-cases 1000] [--memory-duration 1]

The rate of a small VM drifts by +-20 % within a minute, so the serial run, the 2-worker LocalCluster and, as the
ceiling without any engine, two plain processes each running half the cases take turns for `--rounds` rounds: the
efficiency is the median of the rounds' ratios.

Every case is the quarter car with a linear damper FMU on a generated class C road
(`nnfmu.workflows.campaign.quarter_car`).
Cluster start-up and the workers' first imports are timed apart: each engine first runs a few warm-up cases. Beside
the wall-clock rates, the CPU time of every process involved (client, scheduler, nannies, workers) per case: on a
machine shared with other jobs the wall-clock efficiency measures the sharing, while the CPU time shows what the
engine costs (its background part, heartbeats and monitors, grows with the wall time, so load inflates it).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing
import os
import statistics
import tempfile
import time
from pathlib import Path

from nnfmu.cosim.slave import FmuSlave
from nnfmu.workflows.campaign.cases import expand_cases
from nnfmu.workflows.campaign.engine import dask_client, run_dask, run_serial
from nnfmu.workflows.campaign.execute import run_cases
from nnfmu.workflows.campaign.quarter_car import build_quarter_car_system
from nnfmu.workflows.campaign.spec import read_campaign

WARM_UP = 4  # cases each engine runs before it is timed


def campaign(folder: Path, paths: dict[str, Path], name: str, events: int, duration: float, seed: int) -> Path:
    """A campaign file of `events` class C drives (seeds from `seed`) x the linear and the firm damper."""
    variants = "".join(
        f'[[variants]]\nname = "{v}"\nsystem = "{paths["system"]}"\nfmus = {{ damper = "{paths[v]}" }}\n'
        for v in ("linear", "firm")
    )
    text = (
        f'[metrics]\nchannels = ["damper_force", "body_acceleration", "spindle_vertical_force"]\n'
        f'[[events]]\nname = "C-20"\nclass = "C"\nspeed = 20.0\nduration = {duration}\nseed = {seed}\n'
        f"repeats = {events}\n{variants}"
    )
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


def cases_of(path: Path):
    loaded = read_campaign(path)
    return expand_cases(loaded), loaded.blobs


def cpu_seconds() -> float:
    """CPU time [s] of this process and all its descendants alive now (LocalCluster nannies and workers; the
    LocalCluster's scheduler runs in this process)."""
    import psutil

    total = 0.0
    for process in [psutil.Process()] + psutil.Process().children(recursive=True):
        try:
            times = process.cpu_times()
            total += times.user + times.system
        except psutil.NoSuchProcess:
            pass
    return total


def timed_serial(path: Path, warm: Path, reuse_instances: bool = True) -> dict:
    walls: list[float] = []
    cases, blobs = cases_of(warm)
    run_serial(cases, blobs, lambda case, outcome: None, reuse_instances)
    cases, blobs = cases_of(path)
    started, cpu = time.perf_counter(), cpu_seconds()
    run_serial(cases, blobs, lambda case, outcome: walls.append(outcome.wall_s), reuse_instances)
    wall, cpu = time.perf_counter() - started, cpu_seconds() - cpu
    return {
        "reuse_instances": reuse_instances,
        "cases": len(cases),
        "wall_s": wall,
        "cpu_s": cpu,
        "cases_per_hour": len(cases) / wall * 3600,
        "median_case_s": statistics.median(walls),
    }


def timed_dask(client, path: Path) -> dict:
    """The cases of `path` on the client's (warmed-up) cluster."""
    walls: list[float] = []
    cases, blobs = cases_of(path)
    started, cpu = time.perf_counter(), cpu_seconds()
    run_dask(client, cases, blobs, lambda case, outcome: walls.append(outcome.wall_s))
    wall, cpu = time.perf_counter() - started, cpu_seconds() - cpu
    return {
        "cases": len(cases),
        "wall_s": wall,
        "cpu_s": cpu,
        "cases_per_hour": len(cases) / wall * 3600,
        "median_case_s": statistics.median(walls),
    }


def started_cluster(workers: int, warm: Path) -> tuple[contextlib.AbstractContextManager, object, float]:
    """A LocalCluster of `workers`, every worker warmed up (imports, compiled loop, FMUs opened once): (its context,
    the client, start-up time [s])."""
    started = time.perf_counter()
    context = dask_client(None, workers)
    client, _ = context.__enter__()
    up = time.perf_counter() - started
    cases, blobs = cases_of(warm)
    files = {key: blobs[key] if isinstance(blobs[key], bytes) else blobs[key].read_bytes() for key in blobs}
    client.run(run_cases, cases, files)  # on every worker, so none starts cold inside the timed run
    return context, client, up


def _share(path: Path, warm: Path, share: int, shares: int, barrier, walls) -> None:
    """A plain process: warm up, wait for the others, run every `shares`-th event's cases."""
    run_serial(*cases_of(warm), lambda case, outcome: None)
    cases, blobs = cases_of(path)
    events = sorted({case.event.name for case in cases})
    mine = [case for case in cases if events.index(case.event.name) % shares == share]
    barrier.wait()
    started = time.perf_counter()
    run_serial(mine, blobs, lambda case, outcome: None)
    walls.put((len(mine), time.perf_counter() - started))


def timed_processes(path: Path, warm: Path, processes: int) -> dict:
    """The ceiling without any engine: `processes` plain processes, warmed up and started together, each running its
    share of the events (both variants of an event in one process, as a Dask group has them)."""
    context = multiprocessing.get_context("spawn")
    barrier, walls = context.Barrier(processes + 1), context.Queue()
    workers = [
        context.Process(target=_share, args=(path, warm, i, processes, barrier, walls)) for i in range(processes)
    ]
    for worker in workers:
        worker.start()
    barrier.wait()
    started = time.perf_counter()
    done = [walls.get() for _ in workers]
    wall = time.perf_counter() - started
    for worker in workers:
        worker.join()
    cases = sum(n for n, _ in done)
    return {
        "processes": processes,
        "cases": cases,
        "wall_s": wall,
        "cases_per_hour": cases / wall * 3600,
        "process_wall_s": [w for _, w in done],
    }


def worker_state() -> dict:
    """RSS [MB], open file descriptors and memory-mapped regions (each loaded FMU library adds some) of the
    process this runs in (a Dask worker)."""
    import psutil

    process = psutil.Process()
    return {
        "rss_mb": process.memory_info().rss / 1e6,
        "open_fds": process.num_fds(),
        "maps": sum(1 for _ in open(f"/proc/{os.getpid()}/maps")),
    }


def memory(
    folder: Path, paths: dict[str, Path], total: int, duration: float, on_dask: bool, checkpoints: int = 4
) -> dict:
    """The state of one Dask worker (or, `on_dask` False, of this process running the cases serially) after 10
    cases, then after each of `checkpoints` equal blocks up to `total` cases."""
    block = (total - 10) // checkpoints // 2  # events per block (x 2 variants)
    seed = 1000 if on_dask else 100_000
    states, failed, done = {}, [], 0
    started = time.perf_counter()
    with dask_client(None, 1) if on_dask else contextlib.nullcontext((None, None)) as (client, _):
        for i, events in enumerate([5] + [block] * checkpoints):
            cases, blobs = cases_of(campaign(folder, paths, f"memory-{on_dask}-{i}", events, duration, seed))
            seed += events

            def count(case, outcome) -> None:
                if outcome.status != "ok":
                    failed.append(outcome.error)

            if on_dask:
                run_dask(client, cases, blobs, count)
            else:
                run_serial(cases, blobs, count)
            done += len(cases)
            states[done] = next(iter(client.run(worker_state).values())) if on_dask else worker_state()
    return {
        "cases": done,
        "failed": len(failed),
        "wall_s": time.perf_counter() - started,
        "states": states,
        "rss_growth": states[done]["rss_mb"] / states[10]["rss_mb"] - 1.0,
    }


def fmu_setup(paths: dict[str, Path], repeats: int = 200) -> dict:
    """Per FMU: open (extract, load, instantiate, initialise) and close as cosimulate does for every case, against
    terminate + fmi2Reset + initialise on a kept instance."""
    result = {}
    for name in ("vehicle", "linear"):
        started = time.perf_counter()
        for _ in range(repeats):
            slave = FmuSlave(paths[name])
            slave.enter_initialization(0.0)
            slave.exit_initialization()
            slave.close()
        fresh = (time.perf_counter() - started) / repeats
        slave = FmuSlave(paths[name])
        slave.enter_initialization(0.0)
        slave.exit_initialization()
        started = time.perf_counter()
        for _ in range(repeats):
            slave.reset()
            slave.enter_initialization(0.0)
            slave.exit_initialization()
        reset = (time.perf_counter() - started) / repeats
        slave.close()
        result[name] = {"instantiate_ms": fresh * 1e3, "reset_ms": reset * 1e3}
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=400, help="cases of the throughput runs (events x 2 variants)")
    parser.add_argument("--duration", type=float, default=10.0, help="drive length of the throughput cases [s]")
    parser.add_argument("--rounds", type=int, default=5, help="rounds of serial, LocalCluster(2), 2 plain processes")
    parser.add_argument("--memory-cases", type=int, default=1000)
    parser.add_argument("--memory-duration", type=float, default=1.0, help="drive length of the memory cases [s]")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="nnfmu-bench-batch-"))
    paths = build_quarter_car_system(folder / "fmus", {"linear": 2400.0, "firm": 3600.0})
    warm = campaign(folder, paths, "warm", WARM_UP // 2, 1.0, 500)
    measured = campaign(folder, paths, "measured", args.cases // 2, args.duration, 0)
    load = os.getloadavg()
    setup = fmu_setup(paths)
    print(json.dumps({"fmu_setup": setup}), flush=True)
    fresh = timed_serial(measured, warm, reuse_instances=False)
    print(json.dumps({"serial_fresh_instances": fresh}), flush=True)
    context, client, up_1 = started_cluster(1, warm)
    try:
        one = timed_dask(client, measured)
    finally:
        context.__exit__(None, None, None)
    serial_1 = timed_serial(measured, warm)
    print(json.dumps({"local_1": one, "serial": serial_1}), flush=True)
    rounds = []  # serial, LocalCluster(2) and two plain processes in turn: the machine's speed drifts
    for _ in range(args.rounds):
        serial_r = timed_serial(measured, warm)  # no cluster up: its scheduler would share this process
        context, client, up_2 = started_cluster(2, warm)
        try:
            two_r = timed_dask(client, measured)
        finally:
            context.__exit__(None, None, None)
        rounds.append({"serial": serial_r, "local_2": two_r, "processes_2": timed_processes(measured, warm, 2)})
        print(json.dumps({"round": rounds[-1]}), flush=True)

    def median(engine: str, key: str) -> float:
        return statistics.median(r[engine][key] for r in rounds)

    serial = {key: median("serial", key) for key in ("wall_s", "cpu_s", "cases_per_hour", "median_case_s")}
    serial["cases"] = rounds[0]["serial"]["cases"]
    two = {key: median("local_2", key) for key in ("wall_s", "cpu_s", "cases_per_hour", "median_case_s")}
    two["cases"] = rounds[0]["local_2"]["cases"]
    efficiency = [r["local_2"]["cases_per_hour"] / r["serial"]["cases_per_hour"] / 2 for r in rounds]
    ceiling = [r["processes_2"]["cases_per_hour"] / r["serial"]["cases_per_hour"] / 2 for r in rounds]
    rss = memory(folder, paths, args.memory_cases, args.memory_duration, on_dask=True)
    print(json.dumps({"memory_dask_worker": rss}), flush=True)
    plain = memory(folder, paths, args.memory_cases, args.memory_duration, on_dask=False)
    print(json.dumps({"memory_serial": plain}), flush=True)
    per_case_setup = setup["vehicle"]["instantiate_ms"] + setup["linear"]["instantiate_ms"]
    print(
        json.dumps(
            {
                "cases": serial["cases"],
                "drive_s": args.duration,
                "cpu_count": os.cpu_count(),
                "load_average_at_start": [round(x, 2) for x in load],
                "load_average_at_end": [round(x, 2) for x in os.getloadavg()],
                "serial_cases_per_hour": round(serial["cases_per_hour"]),
                "serial_fresh_instances_cases_per_hour": round(fresh["cases_per_hour"]),
                "local_2_cases_per_hour": round(two["cases_per_hour"]),
                "parallel_efficiency": round(statistics.median(efficiency), 3),
                "parallel_efficiency_by_round": [round(e, 3) for e in efficiency],
                "plain_processes_2_efficiency_by_round": [round(e, 3) for e in ceiling],
                "local_2_vs_plain_processes_2": round(
                    statistics.median(
                        r["local_2"]["cases_per_hour"] / r["processes_2"]["cases_per_hour"] for r in rounds
                    ),
                    3,
                ),
                "case_slowdown_two_at_once": round(median("local_2", "median_case_s") / serial["median_case_s"], 3),
                "cpu_s_per_case": {
                    "serial": round(serial["cpu_s"] / serial["cases"], 4),
                    "local_1": round(one["cpu_s"] / one["cases"], 4),
                    "local_2": round(two["cpu_s"] / two["cases"], 4),
                },
                "parallel_efficiency_by_cpu_time": round(serial["cpu_s"] / two["cpu_s"], 3),
                "engine_overhead_per_case_s": round((one["wall_s"] - serial_1["wall_s"]) / serial_1["cases"], 4),
                "local_cluster_start_s": {"1": round(up_1, 2), "2": round(up_2, 2)},
                "fmu_open_per_case_ms": round(per_case_setup, 2),
                "fmu_reset_per_case_ms": round(setup["vehicle"]["reset_ms"] + setup["linear"]["reset_ms"], 4),
                "fmu_open_share_of_fresh_serial_case": round(per_case_setup / 1e3 / fresh["median_case_s"], 3),
                "worker_rss_mb_by_cases": {n: round(state["rss_mb"], 1) for n, state in rss["states"].items()},
                "worker_open_fds_by_cases": {n: state["open_fds"] for n, state in rss["states"].items()},
                "worker_memory_maps_by_cases": {n: state["maps"] for n, state in rss["states"].items()},
                "rss_growth_10_to_last": round(rss["rss_growth"], 4),
                "memory_cases_failed": rss["failed"],
                "serial_rss_mb_by_cases": {n: round(state["rss_mb"], 1) for n, state in plain["states"].items()},
                "serial_open_fds_by_cases": {n: state["open_fds"] for n, state in plain["states"].items()},
                "serial_rss_growth_10_to_last": round(plain["rss_growth"], 4),
            }
        )
    )


if __name__ == "__main__":
    main()
