"""The compiled kernel made ready by a child process: the caller's solve loads it, a child left at work is stopped."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from nnfmu.vehicle.dynamics import kernel_warmup

# In a fresh numba cache: the caller sleeps less than a compile takes, then solves; numba's own counts say whether
# the caller compiled the kernel (a miss) or loaded what the child compiled (a hit).
_CALLER = """
import json, time
from nnfmu.vehicle.dynamics import rk4_kernel
from nnfmu.vehicle.dynamics.kernel_warmup import kernel_compiled_in_background
from nnfmu.vehicle.dynamics.tiny_run import solve_tiny_run
with kernel_compiled_in_background():
    time.sleep(1.0)
    solve_tiny_run()
stats = rk4_kernel.solve.stats
print(json.dumps({"hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values())}))
"""


@pytest.mark.slow
def test_the_callers_first_solve_loads_the_kernel_the_child_compiled(tmp_path: Path) -> None:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    run = subprocess.run([sys.executable, "-c", _CALLER], env=env, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout.splitlines()[-1]) == {"hits": 1, "misses": 0}


def test_a_child_still_compiling_is_stopped_when_the_block_is_left(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))  # a cold cache: the child has ~20 s of work
    with kernel_warmup.kernel_compiled_in_background():
        child = kernel_warmup._child
        assert child is not None and child.poll() is None
    assert child.returncode is not None and child.returncode != 0  # stopped, not left compiling
    assert kernel_warmup._child is None
    kernel_warmup.wait_for_kernel()  # no child: returns at once


def test_a_nested_block_shares_the_outer_child(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    with kernel_warmup.kernel_compiled_in_background():
        outer = kernel_warmup._child
        with kernel_warmup.kernel_compiled_in_background():
            assert kernel_warmup._child is outer
        assert kernel_warmup._child is outer and outer is not None and outer.poll() is None
    assert outer.poll() is not None  # stopped by the outer block alone
