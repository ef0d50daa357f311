"""The suite's compile cache (`tests/compile_cache.py`): identical inputs compiled once, anything else compiled."""

from __future__ import annotations

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
