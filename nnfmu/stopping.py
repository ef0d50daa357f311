"""A stop asked for by a signal, remembered for the whole run.

The command line turns SIGTERM (and Ctrl-C) into a KeyboardInterrupt at once, and also records the request here:
code between the signal and nnfmu may swallow that exception (a library's bare `except:`, a ctypes callback, a
thread pool, interpreter shutdown), and a run that carried on would publish a complete result with exit status 0.
nnfmu checks the request before it publishes anything (`atomic`, `out_paths`) and between the blocks of its long
loops (co-simulation, training), so a stopped run ends with KeyboardInterrupt however the first one was lost.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_requested: list[str] = []  # the reason of the first stop asked for (empty: none)


def request_stop(reason: str) -> None:
    """Remember that the run was asked to stop (`reason`, e.g. "signal 15")."""
    if not _requested:
        _requested.append(reason)


def clear_stop() -> None:
    """Forget a stop asked for (a new command starts in the same process)."""
    _requested.clear()


def stop_requested() -> str | None:
    """The reason of the stop asked for, or None."""
    return _requested[0] if _requested else None


def check_stop() -> None:
    """Raise KeyboardInterrupt if a stop was asked for, however the first interrupt was handled."""
    if _requested:
        raise KeyboardInterrupt(f"{_requested[0]} (stop asked for earlier)")


@contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back for the block and deliver them after it: a temporary made and its cleanup armed
    inside cannot be split by an interrupt (one between mkdtemp and its `try` left a folder behind)."""
    if threading.current_thread() is not threading.main_thread() or any(
        signal.getsignal(number) is None for number in _STOP_SIGNALS
    ):
        yield  # only the main thread runs Python's handlers; one installed outside Python cannot be put back
        return
    held: list[int] = []
    previous = {number: signal.signal(number, lambda signum, _frame: held.append(signum)) for number in _STOP_SIGNALS}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        if held:
            signal.raise_signal(held[0])  # runs the restored handler now, in this thread
