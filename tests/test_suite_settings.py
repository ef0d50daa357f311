"""The suite's own settings (`tests/conftest.py`): the compile cache (`tests/compile_cache.py`) compiles identical
inputs once and anything else anew; FMUs carry the win64 DLL in the build stage's tests and marked ones only."""

from __future__ import annotations

import os
import shutil
import sys
import uuid
from pathlib import Path

import pytest

from nnfmu.fmu.errors import CompilerError
from nnfmu.fmu.native import compiler
from nnfmu.fmu.native.toolchain import host_target

SOURCE = "int nnfmu_cache_probe(void) { return %d; }\n/* %s */\n"  # this run's token: new to any cache
TOKEN = uuid.uuid4().hex


def build(folder: Path, value: int, name: str = "probe.so") -> bytes:
    """A one-function library returning `value`, compiled for this machine; its bytes."""
    source = folder / "src" / "probe.c"
    source.parent.mkdir(parents=True, exist_ok=True)
    source.write_text(SOURCE % (value, TOKEN))
    out = folder / "lib" / name
    compiler.compile_shared_library(host_target(), [source], source.parent, out)
    return out.read_bytes()


def test_identical_inputs_compile_once_and_other_inputs_compile(tmp_path: Path) -> None:
    state = sys.modules["compile_cache"]._state
    assert state["enabled"]  # outside tests/fmu/
    hits, misses = state["hits"], state["misses"]
    first = build(tmp_path / "a", 1)
    again = build(tmp_path / "b", 1)  # the same source in another folder: a copy of the first library
    assert again == first and (state["hits"], state["misses"]) == (hits + 1, misses + 1)
    other = build(tmp_path / "c", 2)  # one byte of source differs: compiled
    renamed = build(tmp_path / "d", 1, "other.so")  # the library's name differs: compiled
    assert other != first and renamed and (state["hits"], state["misses"]) == (hits + 1, misses + 3)


def test_a_failed_compile_is_not_kept(tmp_path: Path) -> None:
    state = sys.modules["compile_cache"]._state
    misses = state["misses"]
    source = tmp_path / "broken.c"
    source.write_text("int broken(void) { return }\n")
    for _ in range(2):
        with pytest.raises(CompilerError, match="C compiler failed"):
            compiler.compile_shared_library(host_target(), [source], tmp_path, tmp_path / "broken.so")
    assert state["misses"] == misses + 2


CHOSEN = pytest.mark.skipif("NNFMU_TEST_WIN64_PLATFORMS" not in os.environ, reason="NNFMU_PLATFORMS set by the caller")


@CHOSEN
def test_fmus_outside_the_build_stage_carry_the_host_binary_alone() -> None:
    assert os.environ["NNFMU_PLATFORMS"] == "host"


@CHOSEN
@pytest.mark.win64
def test_a_win64_test_builds_the_win64_dll_where_mingw_is_installed() -> None:
    mingw = shutil.which("x86_64-w64-mingw32-gcc")
    assert (
        os.environ["NNFMU_PLATFORMS"] == os.environ["NNFMU_TEST_WIN64_PLATFORMS"] == ("host,win64" if mingw else "host")
    )
