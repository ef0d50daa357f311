"""Settings of the whole test suite."""

from __future__ import annotations

import os
import shutil

import pytest

# FMUs the tests build without naming platforms carry this machine's binary and, where MinGW-w64 is installed, the
# win64 DLL (what a default build carried before Zig): a default build with the cross extra compiles five platforms,
# about 6 times the time on a loaded 2-core machine (bench/results/cross-build.json). The default choice itself is
# tested with the variable removed (tests/fmu/test_cross.py, test_win64.py); FMUs built for every platform there.
os.environ.setdefault("NNFMU_PLATFORMS", "host,win64" if shutil.which("x86_64-w64-mingw32-gcc") else "host")

# pytest-xdist runs the suite in one worker process per core (`-n auto` in pyproject.toml, docs/development.md): a
# worker's torch, BLAS and OpenMP then use one thread each instead of every core apiece (set before any of them is
# imported; subprocesses the tests start inherit it).
XDIST_WORKER = os.environ.get("PYTEST_XDIST_WORKER")
if XDIST_WORKER:
    for variable in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(variable, "1")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under xdist, the modules holding slow tests first (each module runs on one worker, `--dist loadfile`): a
    long module started last would leave the other worker idle at the end."""
    if not XDIST_WORKER:
        return
    slow_modules = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow_modules)  # stable: collection order within each part


def pytest_configure(config: object) -> None:
    """Every figure a test saves is checked for cut texts and doubled names (`tests/figure_guard.py`)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("figure_guard", Path(__file__).with_name("figure_guard.py"))
    guard = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(guard)
    guard.install()
