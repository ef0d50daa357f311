"""Compile an FMU's C sources into one shared library per target platform: this machine's, and win64 by cross-compiling.

The host compiler is `$CC` (split like a shell word list, so `CC="gcc -m64"` works) or else `cc`/`gcc`/`clang`; the
win64 compiler is `$CC_WIN64` or else MinGW-w64's `x86_64-w64-mingw32-gcc` (Debian package `gcc-mingw-w64-x86-64`).
Flags are strict on both (`-Wall -Wextra -Werror`, C99) and every symbol except the FMI functions is hidden (ELF
visibility on the host; on Windows the FMI headers mark exactly the FMI functions `__declspec(dllexport)`).
"""

from __future__ import annotations

import os
import platform
import shlex
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path

from nnfmu.fmu.errors import CompilerError

WARNINGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-Wvla")
HOST_FLAGS = (*WARNINGS, "-fPIC", "-shared", "-fvisibility=hidden")
# Static libgcc: the DLL then needs only KERNEL32 and msvcrt. MinGW's own stdio: C99 vsnprintf and printf formats.
WIN64_FLAGS = (*WARNINGS, "-shared", "-static-libgcc", "-D__USE_MINGW_ANSI_STDIO=1")
LIBRARIES = ("-lm",)
COMPILE_TIMEOUT_S = 300
# Set by `host_binaries_only`: platforms None builds the host binary alone.
_HOST_ONLY: ContextVar[bool] = ContextVar("nnfmu_host_binaries_only", default=False)
WIN64 = "win64"
WIN64_COMPILER = "x86_64-w64-mingw32-gcc"
WIN64_INSTALL_HINT = "on Debian/Ubuntu: apt-get install gcc-mingw-w64-x86-64; or set CC_WIN64"


@dataclass(frozen=True)
class Target:
    """A platform an FMU carries a binary for: its name (`--platforms`), binaries folder per FMI version, suffix,
    compiler command and flags."""

    name: str
    fmi2_folder: str | None
    fmi3_folder: str
    suffix: str
    compiler: tuple[str, ...]
    flags: tuple[str, ...]

    def folder(self, fmi_version: int) -> str:
        """The `binaries/` subfolder FMI `fmi_version` names for this platform."""
        if fmi_version == 2:
            if self.fmi2_folder is None:
                raise CompilerError(f"FMI 2.0 defines no binaries folder for {self.fmi3_folder}; build with --fmi 3")
            return self.fmi2_folder
        return self.fmi3_folder


def _host_arch() -> tuple[str, str]:
    system, machine = platform.system(), platform.machine().lower()
    arch = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64", "arm64": "aarch64"}.get(machine)
    if arch is None or system not in ("Linux", "Darwin"):
        raise CompilerError(f"the native backend builds on Linux or macOS (x86_64/arm64), not {system} {machine}")
    return system, arch


def host_compiler() -> tuple[str, ...]:
    """The host C compiler: `$CC` if set, else the first of cc, gcc, clang on PATH."""
    configured = os.environ.get("CC", "").strip()
    if configured:
        return tuple(shlex.split(configured))
    for name in ("cc", "gcc", "clang"):
        found = shutil.which(name)
        if found:
            return (found,)
    raise CompilerError("no C compiler found (set CC or install gcc/clang), or build with --backend pythonfmu")


def host_target() -> Target:
    """This machine's platform (Linux or macOS on x86_64 or arm64) with the host compiler."""
    system, arch = _host_arch()
    if system == "Linux":
        fmi2, fmi3, suffix = ("linux64" if arch == "x86_64" else None), f"{arch}-linux", ".so"
    else:
        fmi2, fmi3, suffix = ("darwin64" if arch == "x86_64" else None), f"{arch}-darwin", ".dylib"
    return Target(fmi2 or fmi3, fmi2, fmi3, suffix, host_compiler(), HOST_FLAGS)


def win64_compiler() -> tuple[str, ...] | None:
    """The win64 cross compiler: `$CC_WIN64` if set, else `x86_64-w64-mingw32-gcc` on PATH; None if neither."""
    configured = os.environ.get("CC_WIN64", "").strip()
    if configured:
        return tuple(shlex.split(configured))
    found = shutil.which(WIN64_COMPILER)
    return (found,) if found else None


def win64_target(compiler: tuple[str, ...]) -> Target:
    """64-bit Windows (`binaries/win64`, `binaries/x86_64-windows`), built by the MinGW-w64 cross compiler."""
    return Target(WIN64, WIN64, "x86_64-windows", ".dll", compiler, WIN64_FLAGS)


def known_platforms() -> tuple[str, ...]:
    """The platform names `--platforms` accepts on this machine: the host's and win64."""
    return (host_target().name, WIN64)


@contextmanager
def host_binaries_only() -> Iterator[None]:
    """Within it, FMUs built without named platforms carry the host's binary only (no win64 cross build, no warning
    about its compiler): the FMUs of a smoke run (`nnfmu demo --quick`) that never leave this machine."""
    token = _HOST_ONLY.set(True)
    try:
        yield
    finally:
        _HOST_ONLY.reset(token)


def select_targets(platforms: tuple[str, ...] | None) -> tuple[list[Target], str | None]:
    """The targets to build and a warning (or None). `platforms` None: the host, plus win64 when its cross compiler
    is present (else a warning saying how to install it; the host alone inside `host_binaries_only`). Named
    platforms: exactly those, each buildable here, else CompilerError naming the platform or the missing compiler."""
    host = host_target()
    if platforms is None and _HOST_ONLY.get():
        return [host], None
    cross = win64_compiler()
    if platforms is None:
        if cross is None:
            return [host], (
                f"no win64 binary: the cross compiler {WIN64_COMPILER} is not installed "
                f"({WIN64_INSTALL_HINT}); the FMU has {host.name} binaries and sources only"
            )
        return [host, win64_target(cross)], None
    targets: list[Target] = []
    for name in dict.fromkeys(platforms):
        if name == host.name:
            targets.append(host)
        elif name == WIN64:
            if cross is None:
                raise CompilerError(
                    f"--platforms {WIN64}: the cross compiler {WIN64_COMPILER} was not found on PATH "
                    f"({WIN64_INSTALL_HINT})"
                )
            targets.append(win64_target(cross))
        else:
            raise CompilerError(f"unknown platform {name!r}; this machine builds {', '.join(known_platforms())}")
    if not targets:
        raise CompilerError(f"no platform given; choose from {', '.join(known_platforms())}")
    return targets, None


def compile_shared_library(target: Target, sources: list[Path], include_dir: Path, output: Path) -> list[str]:
    """Compile `sources` into `target`'s shared library `output`; return the command line used. Raises CompilerError."""
    output.parent.mkdir(parents=True, exist_ok=True)
    command = [
        *target.compiler,
        *target.flags,
        f"-I{include_dir}",
        "-o",
        str(output),
        *(str(s) for s in sources),
        *LIBRARIES,
    ]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=COMPILE_TIMEOUT_S, check=False)
    except (OSError, subprocess.TimeoutExpired) as err:
        raise CompilerError(f"cannot run the {target.name} C compiler {command[0]!r}: {err}") from err
    if result.returncode != 0 or not output.is_file():
        log = (result.stderr or result.stdout).strip()
        raise CompilerError(
            f"the {target.name} C compiler failed (exit {result.returncode}) on {' '.join(command)}:\n{log[-4000:]}"
        )
    return command
