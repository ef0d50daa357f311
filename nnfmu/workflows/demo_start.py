"""What `nnfmu demo` starts before its modules load (several seconds, more on a first run): the run's clock, and the
monolithic kernel's compile in a child process, so the second core works while the first imports."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from nnfmu.vehicle import kernel_compiled_in_background
from nnfmu.workflows.progress import StageClock


@contextmanager
def demo_started(log: Callable[[str], None]) -> Iterator[StageClock]:
    """The demo's clock (hand it to `run_demo`, which closes it), the kernel compiling beside for the whole block."""
    with kernel_compiled_in_background():
        yield StageClock(log)
