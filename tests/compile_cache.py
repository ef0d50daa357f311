"""The suite's compile cache: a shared library compiled once per session for each exact input, copied thereafter.

Workflow tests build the same FMUs again and again (the truth step graphs of every road test, the vehicle FMUs, the
loop's term FMUs): the same generated C, byte for byte, compiled by the same compiler with the same flags. Here
`nnfmu.fmu.native.compiler._compile` looks its inputs up first: the compiler command, its flags, the defines and
libraries asked for, the library's file name, and the name and bytes of every source and of every file of the include
folder. A hit copies the library the
first compile of those inputs made; a miss compiles and keeps what it made. Failed compiles are never kept. The tests
of the build stage itself (`tests/fmu/`, and the build signals of `tests/test_cli_signals.py`) always compile, as do
subprocesses (`nnfmu` run as a command): the cache is this process's, its files shared by the xdist workers of one
session through `$NNFMU_TEST_COMPILE_CACHE` (a temporary folder the controlling process makes and removes).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from pathlib import Path

import pytest

VARIABLE = "NNFMU_TEST_COMPILE_CACHE"
# Where the compiler itself is under test: every build there compiles.
ALWAYS_COMPILED = ("fmu", "test_cli_signals.py")

_state = {"enabled": False, "owned": None, "hits": 0, "misses": 0}


def _key(target, sources: list[Path], include_dir: Path, output: Path, options: dict) -> str:
    """A digest of everything the compiler reads and is told (defines and libraries too), paths of scratch folders
    aside."""
    digest = hashlib.sha256()
    for part in (*target.compiler, "\0", *target.flags, "\0", output.name, repr(sorted(options.items()))):
        digest.update(part.encode() + b"\0")
    files = [(s.name, s) for s in sources]
    files += [(f"include/{p.relative_to(include_dir).as_posix()}", p) for p in sorted(include_dir.rglob("*"))]
    for name, path in files:
        if path.is_file():
            digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def install() -> None:
    """Wrap the compiler call; make the session's cache folder where none is given (the controlling process)."""
    from nnfmu.fmu.native import compiler

    if not os.environ.get(VARIABLE):
        folder = tempfile.mkdtemp(prefix="nnfmu-test-cc-")
        os.environ[VARIABLE] = folder
        _state["owned"] = folder
    compile_now = compiler._compile

    def cached(target, sources, include_dir, output, cwd, **options):
        if not _state["enabled"]:
            return compile_now(target, sources, include_dir, output, cwd, **options)
        kept = Path(os.environ[VARIABLE]) / _key(target, sources, Path(include_dir), output, options)
        if kept.is_file():
            _state["hits"] += 1
            shutil.copyfile(kept, output)
            return [*target.compiler, *target.flags, "-o", str(output), *map(str, sources)]
        _state["misses"] += 1
        command = compile_now(target, sources, include_dir, output, cwd, **options)
        partial = kept.with_name(f"{kept.name}.{os.getpid()}.part")
        shutil.copyfile(output, partial)
        os.replace(partial, kept)  # whole or absent, whichever worker finishes first
        return command

    compiler._compile = cached


def select(item: pytest.Item) -> None:
    """Before `item`'s fixtures are set up: the cache on, except for the tests of the build itself."""
    parts = Path(item.path).relative_to(Path(__file__).parent).parts
    _state["enabled"] = parts[0] not in ALWAYS_COMPILED


def uninstall() -> None:
    """Remove the session's cache folder where this process made it."""
    if _state["owned"]:
        shutil.rmtree(_state["owned"], ignore_errors=True)
