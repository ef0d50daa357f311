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
from nnfmu.export.linear_damper import linear_damper_graph

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


@pytest.mark.slow
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
    [
        ("at once", False),
        pytest.param("while torch loads", False, marks=pytest.mark.slow),
        pytest.param("while torch loads", True, marks=pytest.mark.slow),
    ],
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


SWALLOWING_BUILD = """
import os, signal, sys, time
import nnfmu.workflows.fmu_build as fmu_build
from nnfmu.cli import app

real = fmu_build.build_fmu


def build_in_a_library_that_swallows_interrupts(*args, **kwargs):
    try:  # a library's bare `except:` around a blocking wait, as third-party code has
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)
    except:  # noqa: E722
        pass
    return real(*args, **kwargs)


fmu_build.build_fmu = build_in_a_library_that_swallows_interrupts
sys.argv[0] = "nnfmu"
app()
"""


@pytest.mark.slow
def test_sigterm_swallowed_by_a_library_still_stops_the_run_with_nothing_written(tmp_path: Path) -> None:
    """A SIGTERM whose KeyboardInterrupt a library swallows (a bare `except:`) left the run to finish with exit 0 and
    a complete result (`loop vehicle` ran on 25 s after a SIGTERM): the request is remembered and nothing is
    published, exit 130."""
    model = tmp_path / "damper.onnx"
    onnx.save(linear_damper_graph(2400.0, name="damper"), model)
    script = tmp_path / "swallowing.py"
    script.write_text(SWALLOWING_BUILD, encoding="utf-8")
    out = tmp_path / "out" / "x.fmu"
    done = subprocess.run(
        [sys.executable, str(script), "build", str(model), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 130, (done.returncode, done.stdout, done.stderr)
    assert not out.exists()
    assert not out.parent.exists() or list(out.parent.iterdir()) == [], list(out.parent.iterdir())


def test_a_stop_asked_for_keeps_an_atomic_result_from_being_published(tmp_path: Path) -> None:
    from nnfmu.atomic import atomic_path
    from nnfmu.stopping import clear_stop, request_stop

    target = tmp_path / "result.txt"
    request_stop("signal 15")
    try:
        with pytest.raises(KeyboardInterrupt, match="signal 15"):
            with atomic_path(target) as tmp:
                tmp.write_text("complete", encoding="utf-8")
    finally:
        clear_stop()
    assert list(tmp_path.iterdir()) == []
    with atomic_path(target) as tmp:  # a new command in the same process publishes again
        tmp.write_text("complete", encoding="utf-8")
    assert target.read_text(encoding="utf-8") == "complete"
