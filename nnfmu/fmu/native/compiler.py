"""Compile an FMU's C sources into the shared library for this platform with the system C compiler.

The compiler is `$CC` (split like a shell word list, so `CC="gcc -m64"` works) or else `cc`/`gcc`/`clang`. Flags are
strict (`-Wall -Wextra -Werror`, C99) and every symbol except the FMI functions is hidden.
"""

from __future__ import annotations

import os
import platform
import shlex
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

from nnfmu.fmu.errors import CompilerError

STRICT_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-fPIC", "-shared", "-fvisibility=hidden")
LIBRARIES = ("-lm",)
COMPILE_TIMEOUT_S = 300


@dataclass(frozen=True)
class Platform:
    """Where an FMU keeps its binary for this machine, per FMI version, and the shared-library suffix."""

    fmi2_folder: str | None
    fmi3_folder: str
    suffix: str

    def folder(self, fmi_version: int) -> str:
        if fmi_version == 2:
            if self.fmi2_folder is None:
                raise CompilerError(f"FMI 2.0 defines no binaries folder for {platform.system()} {platform.machine()}; "
                                    "build with --fmi 3")
            return self.fmi2_folder
        return self.fmi3_folder


def host_platform() -> Platform:
    """The FMI platform of this machine (Linux and macOS on x86_64 or arm64)."""
    system, machine = platform.system(), platform.machine().lower()
    arch = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64", "arm64": "aarch64"}.get(machine)
    if arch is None or system not in ("Linux", "Darwin"):
        raise CompilerError(f"the native backend builds on Linux or macOS (x86_64/arm64), not {system} {machine}")
    if system == "Linux":
        return Platform("linux64" if arch == "x86_64" else None, f"{arch}-linux", ".so")
    return Platform("darwin64" if arch == "x86_64" else None, f"{arch}-darwin", ".dylib")


def compiler_command() -> list[str]:
    """The C compiler to run: `$CC` if set, else the first of cc, gcc, clang on PATH."""
    configured = os.environ.get("CC", "").strip()
    if configured:
        return shlex.split(configured)
    for name in ("cc", "gcc", "clang"):
        found = shutil.which(name)
        if found:
            return [found]
    raise CompilerError("no C compiler found (set CC or install gcc/clang), or build with --backend pythonfmu")


def compile_shared_library(sources: list[Path], include_dir: Path, output: Path) -> list[str]:
    """Compile `sources` into the shared library `output`; return the command line used. Raises CompilerError."""
    output.parent.mkdir(parents=True, exist_ok=True)
    command = [*compiler_command(), *STRICT_FLAGS, f"-I{include_dir}", "-o", str(output),
               *(str(s) for s in sources), *LIBRARIES]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=COMPILE_TIMEOUT_S, check=False)
    except (OSError, subprocess.TimeoutExpired) as err:
        raise CompilerError(f"cannot run the C compiler {command[0]!r}: {err}") from err
    if result.returncode != 0 or not output.is_file():
        log = (result.stderr or result.stdout).strip()
        raise CompilerError(f"the C compiler failed (exit {result.returncode}) on {' '.join(command)}:\n{log[-4000:]}")
    return command
