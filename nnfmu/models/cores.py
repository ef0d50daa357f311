"""The cores a search's training runs may use, and the ones its last runs leave idle, lent to their arithmetic."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from typing import TypeVar

_T = TypeVar("_T")


def usable_cores() -> int:
    """Cores this process may run on (its affinity where the system has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


class SpareCores:
    """Counts the cores busy with training runs and lends the others, one task at a time, to the runs still going.

    A search runs one fit per core; once no run is left to start, a core that finishes its last run would sit idle
    while the others finish theirs. `lend` gives it a part of a running fit's epoch instead. A fit holds its core
    with `occupied`; a lent task holds one until it returns.
    """

    def __init__(self, cores: int) -> None:
        self._cores = cores
        self._busy = 0
        self._lock = threading.Lock()
        self._helpers = ThreadPoolExecutor(max_workers=max(1, cores - 1), thread_name_prefix="nnfmu-help")

    @contextmanager
    def occupied(self) -> Iterator[None]:
        """A training run holds one core inside."""
        with self._lock:
            self._busy += 1
        try:
            yield
        finally:
            with self._lock:
                self._busy -= 1

    def lend(self, task: Callable[[], _T]) -> Future[_T] | None:
        """`task` started on an idle core, or None when every core is busy (the caller runs it itself)."""
        with self._lock:
            if self._busy >= self._cores:
                return None
            self._busy += 1
        return self._helpers.submit(self._held, task)

    def _held(self, task: Callable[[], _T]) -> _T:
        try:
            return task()
        finally:  # the core is free before the caller sees the result, so its next epoch may borrow it again
            with self._lock:
                self._busy -= 1

    def close(self) -> None:
        """Stop the helper threads (after the last run)."""
        self._helpers.shutdown()

    def __enter__(self) -> SpareCores:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
