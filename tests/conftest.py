"""Settings of the whole test suite."""

from __future__ import annotations

import os
import shutil

# FMUs the tests build without naming platforms carry this machine's binary and, where MinGW-w64 is installed, the
# win64 DLL (what a default build carried before Zig): a default build with the cross extra compiles five platforms,
# about 6 times the time on a loaded 2-core machine (bench/results/cross-build.json). The default choice itself is
# tested with the variable removed (tests/fmu/test_cross.py, test_win64.py); FMUs built for every platform there.
os.environ.setdefault("NNFMU_PLATFORMS", "host,win64" if shutil.which("x86_64-w64-mingw32-gcc") else "host")
