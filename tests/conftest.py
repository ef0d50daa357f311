"""Settings of the whole test suite."""

from __future__ import annotations

import os
import shutil

# FMUs the tests build without naming platforms carry this machine's binary and, where MinGW-w64 is installed, the
# win64 DLL (what a default build carried before Zig): a default build with the cross extra compiles five platforms,
# about 6 times the time on a loaded 2-core machine (bench/results/cross-build.json). The default choice itself is
# tested with the variable removed (tests/fmu/test_cross.py, test_win64.py); FMUs built for every platform there.
os.environ.setdefault("NNFMU_PLATFORMS", "host,win64" if shutil.which("x86_64-w64-mingw32-gcc") else "host")


def pytest_configure(config: object) -> None:
    """Every figure a test saves is checked for cut texts and doubled names (`tests/figure_guard.py`)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("figure_guard", Path(__file__).with_name("figure_guard.py"))
    guard = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(guard)
    guard.install()
