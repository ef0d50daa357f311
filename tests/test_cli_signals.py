"""A command stopped by SIGTERM (a job scheduler's, a container's or `kill`'s signal) cleans up as one stopped by
Ctrl-C: no hidden temporary stays behind, and no result appears."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import onnx
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.cosim.linear_damper import linear_damper_graph

runner = CliRunner()


def terminated_when(args: list[object], ready: Callable[[], bool], tmpdir: Path) -> subprocess.CompletedProcess:
    """Run `nnfmu ARGS` in a new process with TMPDIR=`tmpdir`, send SIGTERM once `ready()` holds, wait for it."""
    env = dict(os.environ, TMPDIR=str(tmpdir))
    process = subprocess.Popen(
        [sys.executable, "-m", "nnfmu.cli", *map(str, args)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while not ready():
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            out, err = process.communicate()
            pytest.fail(f"the command ended (or took too long) before its temporaries appeared: {out}{err}")
        time.sleep(0.002)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=60)
    return subprocess.CompletedProcess(process.args, process.returncode, out, err)


def ours(folder: Path) -> list[Path]:
    """What lies in `folder` but onnxruntime's own `.ses` file (a session id it keeps in TMPDIR on import)."""
    return [p for p in folder.iterdir() if p.name != ".ses"]


def test_sigterm_during_a_build_leaves_no_temporaries(tmp_path: Path) -> None:
    model = tmp_path / "damper.onnx"
    onnx.save(linear_damper_graph(2400.0, name="damper"), model)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    out = tmp_path / "out" / "x.fmu"
    done = terminated_when(["build", model, "--out", out], lambda: any(scratch.glob("nnfmu-build-*")), scratch)
    assert done.returncode != 0, done.stdout
    assert ours(scratch) == []
    assert not out.exists()
    assert not out.parent.exists() or list(out.parent.iterdir()) == [], list(out.parent.iterdir())


@pytest.mark.slow
def test_sigterm_during_a_loop_leaves_no_staging_folder(tmp_path: Path) -> None:
    data, model = tmp_path / "dyno.csv", tmp_path / "model.onnx"
    made = runner.invoke(app, ["rig", "damper", "--out", str(data), "--duration", "20", "--excitation", "random"])
    assert made.exit_code == 0, made.output
    trained = runner.invoke(
        app,
        [
            "train",
            str(data),
            "--preset",
            "damper-spline",
            "--out",
            str(model),
            "--max-epochs",
            "2",
            "--restarts",
            "1",
            "--hidden",
            "3",
        ],
    )
    assert trained.exit_code == 0, trained.output
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    out = tmp_path / "results" / "loop"
    done = terminated_when(
        ["loop", data, "--model", model, "--out", out, "--max-effects", "1"],
        lambda: out.parent.exists() and any(out.parent.glob(".loop.staging-*")),
        scratch,
    )
    assert done.returncode != 0, done.stdout
    assert list(out.parent.iterdir()) == [], list(out.parent.iterdir())
    assert ours(scratch) == []


@pytest.fixture(scope="module")
def tiny_record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    data = tmp_path_factory.mktemp("record") / "dyno.csv"
    made = runner.invoke(app, ["rig", "damper", "--out", str(data), "--duration", "4", "--excitation", "random"])
    assert made.exit_code == 0, made.output
    return data


def loaded(pid: int, library: str) -> bool:
    """Whether the process has mapped a shared library whose name contains `library` (its import is under way)."""
    try:
        return library in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


@pytest.mark.parametrize(
    "moment, parent_ignores",
    [("at once", False), ("while torch loads", False), ("while torch loads", True)],
)
def test_sigterm_stops_train_at_any_moment_with_130_or_143_and_nothing_left(
    tiny_record: Path, tmp_path: Path, moment: str, parent_ignores: bool
) -> None:
    """SIGTERM right after the start (before nnfmu's handler exists: the default action, 143), while torch is being
    imported, and with SIGTERM left ignored by the parent: one run with an inherited SIG_IGN carried on to exit 0
    and a complete ONNX after SIGTERMs at 3 s and 6 s."""
    scratch, out = tmp_path / "tmp", tmp_path / "out" / "m.onnx"
    scratch.mkdir()
    args = [
        "train",
        tiny_record,
        "--preset",
        "damper-spline",
        "--out",
        out,
        "--max-epochs",
        "100000",
        "--restarts",
        "1",
    ]
    process = subprocess.Popen(
        [sys.executable, "-m", "nnfmu.cli", *map(str, args)],
        env=dict(os.environ, TMPDIR=str(scratch)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=(lambda: signal.signal(signal.SIGTERM, signal.SIG_IGN)) if parent_ignores else None,
    )
    deadline = time.monotonic() + 120
    while moment != "at once" and not loaded(process.pid, "libtorch"):
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"train ended or took too long before loading torch: {process.communicate()}")
        time.sleep(0.002)
    process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        process.kill()
        pytest.fail("train ignored SIGTERM")
    assert process.returncode in (130, -signal.SIGTERM), (process.returncode, err)
    assert not out.exists() and ours(scratch) == []
    assert not out.parent.exists() or list(out.parent.iterdir()) == [], list(out.parent.iterdir())
