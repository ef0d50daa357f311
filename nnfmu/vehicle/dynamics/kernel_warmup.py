"""The monolithic reference's compiled kernel made ready by a child process while the caller does other work.

numba compiles `rk4_kernel.solve` on its first call on a machine (about 20 s of CPU) and caches the machine code on
disk. A run that needs the kernel only later (the demo: its first stage trains networks on one thread) opens
`kernel_compiled_in_background` first: a child process solves a two-sample quarter car (`tiny_run.py`), which
compiles and caches the kernel on another core, and the caller's first compiled solve waits for the child
(`wait_for_kernel`) and then loads the cached code. Where the cache is warm the child only loads it (a few seconds of
CPU, mostly imports); where the child fails, the caller compiles the kernel itself, as without it.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from nnfmu.stopping import interrupts_deferred

# The longest the caller waits for the child [s]: a compile takes ~20 s of CPU on an idle core and several times that
# on a busy machine; past this the caller compiles the kernel itself.
WAIT_LIMIT_S = 600.0
_CHILD_CODE = "from nnfmu.vehicle.dynamics.tiny_run import solve_tiny_run; solve_tiny_run()"
_child: subprocess.Popen[bytes] | None = None


@contextmanager
def kernel_compiled_in_background() -> Iterator[None]:
    """Within it a child process compiles (or loads) the kernel; on leaving, a child still at work is stopped."""
    global _child
    if _child is not None:  # nested: the outer block's child serves
        yield
        return
    root = str(Path(__file__).resolve().parents[3])  # the folder holding the nnfmu package, for the child's imports
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)}
    with interrupts_deferred():  # a stop between the start and the armed cleanup would leave the child running
        child = subprocess.Popen(
            [sys.executable, "-c", _CHILD_CODE],
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        _child = child
    try:
        yield
    finally:
        _child = None
        if child.poll() is None:
            child.terminate()
        child.wait()


def wait_for_kernel() -> None:
    """Before a compiled solve: wait for a child still compiling the kernel (at most WAIT_LIMIT_S)."""
    child = _child
    if child is None:
        return
    try:
        child.wait(WAIT_LIMIT_S)
    except subprocess.TimeoutExpired:
        pass  # compiled here instead, as without the child
