"""Which C compilers build an FMU's binary for which FMI platform here, in order of preference.

Platforms are named by their FMI 3 platform tuple; FMI 2 names the x86_64 ones `linux64`, `win64`, `darwin64` and,
since FMI 2.0.4 (section 2.3), any other platform by its FMI 3 tuple (`aarch64-linux`, `aarch64-darwin`).
Compilers: Zig (`python -m ziglang cc`, the PyPI package of the `nnfmu[cross]` extra) builds every platform, the
Linux ones against glibc 2.17 (the manylinux2014 baseline), the macOS ones for macOS 11 and later; the host compiler
(`$CC`, else cc/gcc/clang) builds this machine's platform against this machine's C library; MinGW-w64 (`$CC_WIN64`,
else `x86_64-w64-mingw32-gcc`) builds 64-bit Windows. Preference: `$CC` when set, then Zig, then cc for a Linux host
(the glibc baseline is what makes a Linux binary portable); the host compiler first on macOS; MinGW before Zig for
Windows (Zig's first Windows build compiles its C runtime into Zig's cache, minutes to half an hour).
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import os
import platform as host_platform
import shlex
import shutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

from nnfmu.fmu.errors import CompilerError

# -ffp-contract=off: no fused multiply-add on any target (aarch64 has FMA), so every platform rounds alike. -O3: gcc
# vectorises the generated loops there (without -ffast-math nothing is reassociated, so the results stay bit for bit):
# `bench/cosim.py` full vehicle, 50 s, the demo's networks, gcc 12 0.37 s at -O2, 0.28 s at -O3; Zig 0.232 s at both.
WARNINGS = ("-std=c99", "-O3", "-Wall", "-Wextra", "-Werror", "-Wvla", "-ffp-contract=off")
HOST_FLAGS = (*WARNINGS, "-fPIC", "-shared", "-fvisibility=hidden")
# Static libgcc: the DLL then needs only KERNEL32 and msvcrt. MinGW's own stdio: C99 vsnprintf and printf formats.
WIN64_FLAGS = (*WARNINGS, "-shared", "-static-libgcc", "-D__USE_MINGW_ANSI_STDIO=1")
ZIG_WINDOWS_FLAGS = (*WARNINGS, "-shared", "-D__USE_MINGW_ANSI_STDIO=1")
WIN64_COMPILER = "x86_64-w64-mingw32-gcc"
ZIG_MODULE = "ziglang"
GLIBC_BASELINE = "2.17"
MACOS_BASELINE = "11.0"  # Big Sur: the first macOS on Apple silicon
CROSS_HINT = "pip install 'nnfmu[cross]' (the Zig toolchain)"
WIN64_HINT = "for x86_64-windows also: apt-get install gcc-mingw-w64-x86-64, or set CC_WIN64"
# The default choice of platforms where none are named, as `--platforms` takes them (unset: every buildable one).
PLATFORMS_VARIABLE = "NNFMU_PLATFORMS"
# Set by `host_binaries_only`: a default build (no platforms named) builds the host's binary alone.
_HOST_ONLY: ContextVar[bool] = ContextVar("nnfmu_host_binaries_only", default=False)


@dataclass(frozen=True)
class Platform:
    """An FMI platform: its FMI 3 tuple (the name `--platforms` takes), FMI 2 folder, library suffix, Zig target."""

    name: str
    fmi2_folder: str
    suffix: str
    zig_target: str

    def folder(self, fmi_version: int) -> str:
        """The `binaries/` subfolder FMI `fmi_version` names for this platform."""
        return self.fmi2_folder if fmi_version == 2 else self.name


PLATFORMS = (
    Platform("x86_64-linux", "linux64", ".so", f"x86_64-linux-gnu.{GLIBC_BASELINE}"),
    Platform("aarch64-linux", "aarch64-linux", ".so", f"aarch64-linux-gnu.{GLIBC_BASELINE}"),
    Platform("x86_64-windows", "win64", ".dll", "x86_64-windows-gnu"),
    Platform("x86_64-darwin", "darwin64", ".dylib", f"x86_64-macos.{MACOS_BASELINE}"),
    Platform("aarch64-darwin", "aarch64-darwin", ".dylib", f"aarch64-macos.{MACOS_BASELINE}"),
)
BY_NAME = {name: p for p in PLATFORMS for name in (p.name, p.fmi2_folder)}


@dataclass(frozen=True)
class Target:
    """A platform with the compiler that builds it: command, flags, and how the build names it (`label`)."""

    platform: Platform
    compiler: tuple[str, ...]
    flags: tuple[str, ...]
    label: str

    @property
    def name(self) -> str:
        """The platform's FMI 3 tuple."""
        return self.platform.name

    @property
    def suffix(self) -> str:
        """The shared library's file suffix."""
        return self.platform.suffix

    def folder(self, fmi_version: int) -> str:
        """The `binaries/` subfolder FMI `fmi_version` names for this platform."""
        return self.platform.folder(fmi_version)


def host_platform_of() -> Platform:
    """This machine's platform (Linux or macOS on x86_64 or arm64). Raises CompilerError elsewhere."""
    system, machine = host_platform.system(), host_platform.machine().lower()
    arch = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64", "arm64": "aarch64"}.get(machine)
    if arch is None or system not in ("Linux", "Darwin"):
        raise CompilerError(f"the native backend builds on Linux or macOS (x86_64/arm64), not {system} {machine}")
    return BY_NAME[f"{arch}-{'linux' if system == 'Linux' else 'darwin'}"]


def _host_command() -> tuple[str, ...] | None:
    """`$CC` (split like a shell word list, so `CC="gcc -m64"` works), else the first of cc, gcc, clang on PATH."""
    configured = os.environ.get("CC", "").strip()
    if configured:
        return tuple(shlex.split(configured))
    found = next((shutil.which(name) for name in ("cc", "gcc", "clang") if shutil.which(name)), None)
    return (found,) if found else None


def host_target() -> Target:
    """This machine's platform with the host compiler (`$CC`, else cc/gcc/clang): what builds helpers this process
    loads itself. Raises CompilerError when there is none."""
    command = _host_command()
    if command is None:
        raise CompilerError("no C compiler found (set CC or install gcc/clang), or build with --backend pythonfmu")
    return Target(host_platform_of(), command, HOST_FLAGS, f"host compiler {shlex.join(command)}")


def _zig_target(target: Platform) -> Target | None:
    """Zig for `target` when the `ziglang` package is installed (the cross extra), else None."""
    if importlib.util.find_spec(ZIG_MODULE) is None:
        return None
    version = importlib.metadata.version(ZIG_MODULE)
    flags = ZIG_WINDOWS_FLAGS if target.suffix == ".dll" else HOST_FLAGS
    baseline = {".so": f", glibc {GLIBC_BASELINE}", ".dylib": f", macOS {MACOS_BASELINE}"}.get(target.suffix, "")
    command = (sys.executable, "-m", ZIG_MODULE, "cc", "-target", target.zig_target)
    return Target(target, command, flags, f"Zig {version}{baseline}")


def _mingw_target(target: Platform) -> Target | None:
    """MinGW-w64 for 64-bit Windows: `$CC_WIN64`, else `x86_64-w64-mingw32-gcc` on PATH; None if neither."""
    configured = os.environ.get("CC_WIN64", "").strip()
    command = tuple(shlex.split(configured)) if configured else (shutil.which(WIN64_COMPILER),)
    if command[0] is None:
        return None
    return Target(target, command, WIN64_FLAGS, f"MinGW-w64 {shlex.join(command)}")


def candidates(target: Platform) -> list[Target]:
    """The compilers present here that build `target`, best first (see the module's docstring)."""
    found: list[Target | None]
    if target.name == "x86_64-windows":
        found = [_mingw_target(target), _zig_target(target)]
    elif target == host_platform_of():
        host = _host_command()
        native = None if host is None else Target(target, host, HOST_FLAGS, f"host compiler {shlex.join(host)}")
        # The host compiler first where CC names it, on macOS, and for binaries that never leave this machine
        # (`host_binaries_only`: no glibc baseline to keep, and gcc compiles them in about half Zig's time).
        prefer_host = bool(os.environ.get("CC", "").strip()) or target.name.endswith("darwin") or _HOST_ONLY.get()
        found = [native, _zig_target(target)] if prefer_host else [_zig_target(target), native]
    else:
        found = [_zig_target(target)]
    return [t for t in found if t is not None]


def _hint(missing: list[Platform]) -> str:
    """How to get the compilers of the `missing` platforms."""
    windows = any(p.name == "x86_64-windows" for p in missing)
    return f"{CROSS_HINT}; {WIN64_HINT}" if windows else CROSS_HINT


def platform_names() -> str:
    """The names `--platforms` takes, for messages and `--help`."""
    return "host, all, or " + ", ".join(
        f"{p.name} ({p.fmi2_folder})" if p.fmi2_folder != p.name else p.name for p in PLATFORMS
    )


def _named(platforms: tuple[str, ...], asked: str) -> list[Platform]:
    """The platforms `platforms` names (`host`, `all`, FMI 3 tuples, FMI 2 folders), each once; CompilerError naming
    `asked` (the option or variable they came from) on an unknown name or none."""
    chosen: list[Platform] = []
    for name in platforms:
        if name == "all":
            chosen.extend(PLATFORMS)
        elif name == "host":
            chosen.append(host_platform_of())
        elif name in BY_NAME:
            chosen.append(BY_NAME[name])
        else:
            raise CompilerError(f"{asked}: unknown platform {name!r}; choose from {platform_names()}")
    if not chosen:
        raise CompilerError(f"{asked}: no platform given; choose from {platform_names()}")
    return list(dict.fromkeys(chosen))


@contextmanager
def host_binaries_only() -> Iterator[None]:
    """Within it, FMUs built without named platforms carry the host's binary only (no cross builds, no warning about
    their compilers): the FMUs of a smoke run (`nnfmu demo --quick`) that never leave this machine."""
    token = _HOST_ONLY.set(True)
    try:
        yield
    finally:
        _HOST_ONLY.reset(token)


def select_targets(platforms: tuple[str, ...] | None) -> tuple[list[Target], str | None]:
    """The targets to build and a warning naming the platforms left out and why (or None).

    `platforms` None: those `$NNFMU_PLATFORMS` names where it is set (the host's alone inside `host_binaries_only`),
    else every platform a compiler here builds, the rest named in the warning with how to get their compiler. Named
    platforms (FMI 3 tuples, FMI 2 folder names, `host`, `all`): exactly those, else CompilerError naming each
    platform without a compiler."""
    asked = "--platforms"
    if platforms is None and _HOST_ONLY.get():
        platforms = ("host",)
    elif platforms is None and os.environ.get(PLATFORMS_VARIABLE, "").strip():
        platforms, asked = tuple(os.environ[PLATFORMS_VARIABLE].split(",")), f"${PLATFORMS_VARIABLE}"
    wanted = list(PLATFORMS) if platforms is None else _named(tuple(n.strip() for n in platforms if n.strip()), asked)
    targets, missing = [], []
    for target in wanted:
        found = candidates(target)
        if found:
            targets.append(found[0])
        else:
            missing.append(target)
    if platforms is not None and missing:
        raise CompilerError(
            f"{asked} {','.join(platforms)}: no compiler here builds {', '.join(p.name for p in missing)} "
            f"({_hint(missing)})"
        )
    if not targets:
        raise CompilerError("no C compiler found (set CC or install gcc/clang), or build with --backend pythonfmu")
    if not missing:
        return targets, None
    return targets, (
        f"no binaries for {', '.join(p.name for p in missing)}: no compiler for them here ({_hint(missing)}); "
        f"the FMU has {', '.join(t.name for t in targets)} binaries and its sources"
    )
