"""One use case run in a child process beside the caller's own work, on another core.

Some of the demo's stages need nothing any other stage makes (the component networks, the component loop): `Beside`
runs each in a spawned child process from the start, so a two-core machine keeps both cores busy until the end. The
child's log lines reach the caller as they come; `result()` waits for its return value or raises its error in the
caller; leaving the `beside` block early stops the child.
"""

from __future__ import annotations

import multiprocessing
import queue
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, Generic, TypeVar

from nnfmu.errors import NnfmuError

T = TypeVar("T")
# How often the caller's reader looks whether a silent child is still alive [s].
POLL_S = 0.5


class BesideError(NnfmuError):
    """The child process failed: its error, or its exit without a result, named with what it was running."""


class Beside(Generic[T]):
    """`function(*args, log=...)` running in a child process; its log lines passed to `log` by a reader thread."""

    def __init__(self, what: str, function: Callable[..., T], args: tuple[Any, ...], log: Callable[[str], None]):
        context = multiprocessing.get_context("spawn")  # a fresh interpreter: no threads or locks of this process
        self._what = what
        self._messages = context.Queue()
        self._process = context.Process(
            target=_child, args=(self._messages, function, args), name=f"nnfmu-{what}", daemon=True
        )
        self._log = log
        self._done = threading.Event()
        self._outcome: tuple[str, Any] | None = None
        self.seconds = 0.0
        self._started = time.perf_counter()
        self._process.start()
        self._reader = threading.Thread(target=self._read, name=f"nnfmu-{what}-reader", daemon=True)
        self._reader.start()

    def result(self) -> T:
        """Wait for the child; its return value, or its error raised here as a BesideError naming what it ran."""
        self._done.wait()
        self._process.join()
        kind, value = self._outcome if self._outcome is not None else ("lost", None)
        if kind == "done":
            return value
        if kind == "error":
            raise BesideError(f"{self._what} (in its own process) failed: {value}")
        raise BesideError(f"{self._what} (in its own process) ended with exit code {self._process.exitcode}, no result")

    def stop(self) -> None:
        """End the child now if it still runs (the caller is leaving early)."""
        if self._process.is_alive():
            self._process.terminate()
        self._process.join()
        self._done.set()

    def _read(self) -> None:
        while not self._done.is_set():
            try:
                kind, value = self._messages.get(timeout=POLL_S)
            except queue.Empty:
                if not self._process.is_alive():  # died without a word (killed, or a crash in C)
                    self.seconds = time.perf_counter() - self._started
                    self._done.set()
                continue
            if kind == "log":
                self._log(value)
            else:
                self.seconds = time.perf_counter() - self._started
                self._outcome = (kind, value)
                self._done.set()


@contextmanager
def beside(
    what: str, function: Callable[..., T], args: tuple[Any, ...], log: Callable[[str], None]
) -> Iterator[Beside[T]]:
    """`Beside` for the block; the child stopped when the block is left before `result()` was taken."""
    run = Beside(what, function, args, log)
    try:
        yield run
    finally:
        run.stop()


def _child(messages: Any, function: Callable[..., Any], args: tuple[Any, ...]) -> None:
    """In the child: run `function`, sending its log lines, then its result or its error (as text with its origin)."""
    try:
        result = function(*args, log=lambda line: messages.put(("log", line)))
    except BaseException as error:  # noqa: BLE001 - every failure must reach the caller, which raises it
        where = traceback.extract_tb(error.__traceback__)[-1]
        messages.put(("error", f"{type(error).__name__}: {error} (at {where.filename}:{where.lineno})"))
    else:
        messages.put(("done", result))
    messages.close()
    messages.join_thread()
