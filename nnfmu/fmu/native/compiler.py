"""Compile an FMU's C sources into one shared library per target platform: every source of every target compiled to
an object in parallel (at most one compiler per CPU in the process), then one link per target.

Which compiler builds which platform is `toolchain.py`'s; here each target's command runs with its strict flags
(`-Wall -Wextra -Werror -Wvla`, C99 on every target) and every symbol except the FMI functions hidden (ELF and Mach-O
visibility; on Windows the FMI headers mark exactly the FMI functions `__declspec(dllexport)`). Compiling the sources
one by one instead of in one command halves a host build's wall time on two cores (the three sources of a network FMU
take 0.2-0.4 s of CPU each). Zig keeps what it compiled in its own cache (`~/.cache/zig`), so a rebuild of unchanged
sources takes about a second per target.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import threading
from concurrent.futures import ThreadPoolExecutor, wait
from pathlib import Path

from nnfmu.atomic import scratch_dir
from nnfmu.fmu.errors import CompilerError
from nnfmu.fmu.native.toolchain import Target

LIBRARIES = ("-lm",)
COMPILE_TIMEOUT_S = 300
# Flags only the link step takes (a compile-only command given them fails under clang's -Werror as unused arguments).
LINK_ONLY_FLAGS = frozenset({"-shared", "-static-libgcc"})
_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def compile_shared_library(
    target: Target,
    sources: list[Path],
    include_dir: Path,
    output: Path,
    defines: tuple[str, ...] = (),
    libraries: tuple[str, ...] = LIBRARIES,
) -> None:
    """Compile `sources` into `target`'s shared library `output`, nothing else beside it (a linker's by-products, such
    as Zig's `.pdb` and import `.lib` on Windows, stay in a scratch folder). `defines` (`-DNAME`) and `libraries`
    (`-lm`, `-ldl`) for the sources that need them. Raises CompilerError."""
    output.parent.mkdir(parents=True, exist_ok=True)
    with scratch_dir(f"nnfmu-cc-{target.name}-") as scratch:
        built = Path(scratch) / output.name
        extra = {"defines": defines, "libraries": libraries} if defines or libraries != LIBRARIES else {}
        _compile(target, sources, include_dir, built, Path(scratch), **extra)
        shutil.move(built, output)


def compile_all(builds: list[tuple[Target, Path]], sources: list[Path], include_dir: Path) -> None:
    """Compile `sources` once per (target, output library), the targets side by side (their objects share the one
    pool of compilers). The first failure in the order given is raised (CompilerError) once every target has ended."""
    with ThreadPoolExecutor(max_workers=max(1, len(builds)), thread_name_prefix="nnfmu-target") as pool:
        futures = [pool.submit(compile_shared_library, t, sources, include_dir, out) for t, out in builds]
    for future in futures:
        future.result()


def _compile(
    target: Target,
    sources: list[Path],
    include_dir: Path,
    output: Path,
    cwd: Path,
    defines: tuple[str, ...] = (),
    libraries: tuple[str, ...] = LIBRARIES,
) -> None:
    """`sources` compiled to objects in `cwd` in parallel, then linked into `output`. On a failure the sources not yet
    started are not compiled; the first failure in the order given is raised (CompilerError) once the compilers
    running have finished."""
    objects = [cwd / f"{n}-{source.stem}.o" for n, source in enumerate(sources)]
    futures = [
        _object_pool().submit(_compile_object, target, source, include_dir, obj, defines)
        for source, obj in zip(sources, objects, strict=True)
    ]
    try:
        for future in futures:
            future.result()
    finally:
        for future in futures:
            future.cancel()
        wait(futures)
    _link(target, objects, output, cwd, libraries)


def _object_pool() -> ThreadPoolExecutor:
    """The process's compilers: at most one per CPU, shared by every library compiled at the same time."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max_workers=max(1, os.cpu_count() or 1), thread_name_prefix="nnfmu-cc")
        return _POOL


def _forget_pool() -> None:
    """In a forked child: the parent's compiler threads do not exist there, so its pool is made anew on first use."""
    global _POOL, _POOL_LOCK
    _POOL, _POOL_LOCK = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_pool)


def _compile_object(target: Target, source: Path, include_dir: Path, output: Path, defines: tuple[str, ...]) -> None:
    """`source` compiled by `target`'s compiler into the object `output`. Raises CompilerError."""
    flags = [flag for flag in target.flags if flag not in LINK_ONLY_FLAGS]
    command = [*target.compiler, *flags, *defines, f"-I{include_dir.resolve()}", "-c", "-o", str(output)]
    _run(target, [*command, str(source.resolve())], output.parent, output)


def _link(target: Target, objects: list[Path], output: Path, cwd: Path, libraries: tuple[str, ...]) -> None:
    """`objects` linked by `target`'s compiler into the shared library `output`. Raises CompilerError."""
    # A dylib's install name is the path it was linked at unless set: the FMU's own name instead of a build folder.
    install_name = (f"-Wl,-install_name,@rpath/{output.name}",) if target.suffix == ".dylib" else ()
    flags = [flag for flag in target.flags if flag in LINK_ONLY_FLAGS]
    command = [*target.compiler, *flags, *install_name, "-o", str(output), *map(str, objects), *libraries]
    _run(target, command, cwd, output)


def _run(target: Target, command: list[str], cwd: Path, output: Path) -> None:
    """Run one compiler command in `cwd` that must write `output`. Raises CompilerError with its log."""
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
