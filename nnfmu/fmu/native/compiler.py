"""Compile an FMU's C sources into one shared library per target platform, the platforms in parallel.

Which compiler builds which platform is `toolchain.py`'s; here each target's command runs with its strict flags
(`-Wall -Wextra -Werror -Wvla`, C99 on every target) and every symbol except the FMI functions hidden (ELF and Mach-O
visibility; on Windows the FMI headers mark exactly the FMI functions `__declspec(dllexport)`). Zig keeps what it
compiled in its own cache (`~/.cache/zig`), so a rebuild of unchanged sources takes about a second per target.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from nnfmu.atomic import scratch_dir
from nnfmu.fmu.errors import CompilerError
from nnfmu.fmu.native.toolchain import Target

LIBRARIES = ("-lm",)
COMPILE_TIMEOUT_S = 300


def compile_shared_library(
    target: Target,
    sources: list[Path],
    include_dir: Path,
    output: Path,
    defines: tuple[str, ...] = (),
    libraries: tuple[str, ...] = LIBRARIES,
) -> list[str]:
    """Compile `sources` into `target`'s shared library `output`, nothing else beside it (a linker's by-products, such
    as Zig's `.pdb` and import `.lib` on Windows, stay in a scratch folder); return the command line used. `defines`
    (`-DNAME`) and `libraries` (`-lm`, `-ldl`) for the sources that need them. Raises CompilerError."""
    output.parent.mkdir(parents=True, exist_ok=True)
    with scratch_dir(f"nnfmu-cc-{target.name}-") as scratch:
        built = Path(scratch) / output.name
        extra = {"defines": defines, "libraries": libraries} if defines or libraries != LIBRARIES else {}
        command = _compile(target, sources, include_dir, built, Path(scratch), **extra)
        shutil.move(built, output)
    return command


def _compile(
    target: Target,
    sources: list[Path],
    include_dir: Path,
    output: Path,
    cwd: Path,
    defines: tuple[str, ...] = (),
    libraries: tuple[str, ...] = LIBRARIES,
) -> list[str]:
    """Run `target`'s compiler on `sources` into `output`, in `cwd`; the command line used. Raises CompilerError."""
    # A dylib's install name is the path it was linked at unless set: the FMU's own name instead of a build folder.
    install_name = (f"-Wl,-install_name,@rpath/{output.name}",) if target.suffix == ".dylib" else ()
    command = [
        *target.compiler,
        *target.flags,
        *install_name,
        *defines,
        f"-I{include_dir.resolve()}",
        "-o",
        str(output),
        *(str(s.resolve()) for s in sources),
        *libraries,
    ]
    try:
        result = subprocess.run(
            command, capture_output=True, text=True, timeout=COMPILE_TIMEOUT_S, check=False, cwd=cwd
        )
    except (OSError, subprocess.TimeoutExpired) as err:
        raise CompilerError(f"cannot run the {target.name} C compiler {command[0]!r}: {err}") from err
    if result.returncode != 0 or not output.is_file():
        log = (result.stderr or result.stdout).strip()
        raise CompilerError(
            f"the {target.name} C compiler failed ({target.label}, exit {result.returncode}) on "
            f"{' '.join(command)}:\n{log[-4000:]}"
        )
    return command


def compile_all(builds: list[tuple[Target, Path]], sources: list[Path], include_dir: Path) -> None:
    """Compile `sources` once per (target, output library), at most one compiler per CPU at a time. The first failure
    in the order given is raised (CompilerError) once the compilers running then have finished; queued ones never
    start."""
    workers = max(1, min(len(builds), os.cpu_count() or 1))
    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="nnfmu-cc")
    try:
        futures = [pool.submit(compile_shared_library, t, sources, include_dir, out) for t, out in builds]
        for future in futures:
            future.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
