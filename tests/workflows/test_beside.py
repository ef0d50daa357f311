"""A use case in a child process beside the caller: its log lines and result come back, its failures are raised
naming what it ran, and a caller leaving early stops it."""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import pytest

from nnfmu.errors import NnfmuError, SettingsError
from nnfmu.workflows.beside import Beside, BesideError, beside


def squares(count: int, log: Callable[[str], None]) -> list[int]:
    for n in range(count):
        log(f"square of {n}")
    return [n * n for n in range(count)]


def refuses(log: Callable[[str], None]) -> None:
    log("about to refuse")
    raise SettingsError("step = -1 s must be positive")


def dies(log: Callable[[str], None]) -> None:
    os._exit(3)  # as a crash in C would: no word to the caller


def sleeps(pid_file: str, log: Callable[[str], None]) -> None:
    with open(pid_file, "w") as handle:
        handle.write(str(os.getpid()))
    time.sleep(60)


def test_the_childs_log_lines_and_result_reach_the_caller() -> None:
    lines: list[str] = []
    with beside("squares", squares, (4,), lines.append) as run:
        assert run.result() == [0, 1, 4, 9]
    assert lines == [f"square of {n}" for n in range(4)] and run.seconds > 0


def test_the_childs_error_is_raised_naming_what_it_ran() -> None:
    lines: list[str] = []
    with beside("the component loop", refuses, (), lines.append) as run:
        with pytest.raises(BesideError, match=r"the component loop .*failed: SettingsError: step = -1 s must be"):
            run.result()
    assert lines == ["about to refuse"] and issubclass(BesideError, NnfmuError)


def test_a_child_that_dies_without_a_word_is_an_error_with_its_exit_code() -> None:
    with beside("a crash", dies, (), lambda line: None) as run:
        with pytest.raises(BesideError, match="a crash .*exit code 3, no result"):
            run.result()


def test_leaving_the_block_early_stops_the_child(tmp_path) -> None:
    pid_file = tmp_path / "pid"
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        with beside("a sleeper", sleeps, (str(pid_file),), lambda line: None):
            while not pid_file.exists() or not pid_file.read_text():
                time.sleep(0.05)
            raise KeyboardInterrupt  # the user's Ctrl-C in the caller's own work
    pid = int(pid_file.read_text())
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # gone (joined, so not even a zombie)
    assert time.perf_counter() - started < 30


def test_a_stopped_run_has_no_result() -> None:
    run = Beside("squares", squares, (2,), lambda line: None)
    run.stop()
    with pytest.raises(BesideError, match="squares"):
        run.result()
