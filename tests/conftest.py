"""Settings of the whole test suite."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

# FMUs the tests of the build stage (`tests/fmu/`) and tests marked `win64` build without naming platforms carry this
# machine's binary and, where MinGW-w64 is installed, the win64 DLL (what a default build carried before Zig); every
# other test's FMUs carry the host's binary alone (they never look at another; the win64 compile was 9-10 s of CPU for
# a full car's truth FMUs). A default build with the cross extra compiles five platforms, about 6 times the time on a
# loaded 2-core machine (bench/results/cross-build.json). The default choice itself is tested with the variable
# removed (tests/fmu/test_cross.py, test_win64.py); FMUs built for every platform there. A value set before the
# suite starts is kept for every test.
# An xdist worker inherits the controller's environment: NNFMU_TEST_WIN64_PLATFORMS marks a value this file set.
PLATFORMS_SET = "NNFMU_PLATFORMS" in os.environ and "NNFMU_TEST_WIN64_PLATFORMS" not in os.environ
WITH_WIN64 = "host,win64" if shutil.which("x86_64-w64-mingw32-gcc") else "host"
os.environ.setdefault("NNFMU_PLATFORMS", WITH_WIN64)
if not PLATFORMS_SET:
    os.environ["NNFMU_TEST_WIN64_PLATFORMS"] = WITH_WIN64  # what marked tests get (tests/test_suite_settings.py)

# pytest-xdist runs the suite in one worker process per core (`-n auto` in pyproject.toml, docs/development.md): a
# worker's torch, BLAS and OpenMP then use one thread each instead of every core apiece (set before any of them is
# imported; subprocesses the tests start inherit it).
XDIST_WORKER = os.environ.get("PYTEST_XDIST_WORKER")
if XDIST_WORKER:
    for variable in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(variable, "1")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under xdist, the modules holding slow tests first (each module runs on one worker, `--dist loadfile`): a
    long module started last would leave the other worker idle at the end. xdist keeps this order only with
    `--no-loadscope-reorder` (pyproject.toml); by default it hands out the modules with the most tests first."""
    if not XDIST_WORKER:
        return
    slow_modules = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow_modules)  # stable: collection order within each part


def _helper(name: str):
    """A helper module beside this file (the suite is imported with `--import-mode=importlib`, not as a package)."""
    import importlib.util
    import sys
    from pathlib import Path

    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name(f"{name}.py"))
        sys.modules[name] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(sys.modules[name])
    return sys.modules[name]


def pytest_configure(config: object) -> None:
    """Every figure a test saves is checked for cut texts and doubled names (`tests/figure_guard.py`); compiles of
    identical inputs are made once per session outside the build stage's own tests (`tests/compile_cache.py`); nnfmu's
    own cache (compiled helpers, system FMUs) lies in that session's folder, not the user's, unless `$NNFMU_CACHE`
    names one."""
    _helper("figure_guard").install()
    compile_cache = _helper("compile_cache")
    compile_cache.install()
    os.environ.setdefault("NNFMU_CACHE", str(Path(os.environ[compile_cache.VARIABLE]) / "nnfmu-cache"))


def pytest_unconfigure(config: object) -> None:
    """The session's compile cache removed by the process that made it."""
    _helper("compile_cache").uninstall()


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    """The compile cache on or off and the default platforms of `item`'s FMUs, before its fixtures are set up."""
    _helper("compile_cache").select(item)
    if not PLATFORMS_SET:
        build_stage = Path(item.path).relative_to(Path(__file__).parent).parts[0] == "fmu"
        os.environ["NNFMU_PLATFORMS"] = WITH_WIN64 if build_stage or item.get_closest_marker("win64") else "host"
