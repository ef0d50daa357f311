"""The C masters of test_memcheck.py (fmi2_driver.c, fmi3_driver.c) built for another platform and their printed
outputs compared: shared by the win64 (wine) and aarch64-linux (qemu-user) tests."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
from fmpy import read_model_description

from nnfmu.fmu.native.backend import fmi_headers_dir

# The brief's bound, relative to each output's largest magnitude over the run. msvcrt's tanh and glibc's differ in
# the last bit for some arguments: measured 1.6e-16 and 2.9e-16 of the peak (8.5e-15 of a value near a zero crossing).
RELATIVE = 1e-15


def counts(path: Path) -> tuple[str, str, int, int]:
    """The FMU's model identifier, instantiation token, number of inputs and of real outputs."""
    md = read_model_description(str(path))
    n_in = sum(v.causality == "input" for v in md.modelVariables)
    n_out = sum(v.causality == "output" and v.type in ("Real", "Float64") for v in md.modelVariables)
    return md.coSimulation.modelIdentifier, md.guid, n_in, n_out


def build_driver(compiler: list[str], fmi: int, target: Path, extra: list[str]) -> Path:
    """fmi`fmi`_driver.c compiled by `compiler` (a command line) into `target`, warnings as errors."""
    return compile_driver(Path(__file__).with_name(f"fmi{fmi}_driver.c"), compiler, target, extra)


def compile_driver(source: Path, compiler: list[str], target: Path, extra: list[str]) -> Path:
    """A C master `source` (which may include driver_common.h from here) compiled by `compiler` into `target`,
    warnings as errors, with `extra` flags and libraries and libm."""
    flags = [
        "-std=c99",
        "-O2",
        "-Wall",
        "-Wextra",
        "-Werror",
        *extra,
        f"-I{fmi_headers_dir()}",
        f"-I{Path(__file__).parent}",
    ]
    subprocess.run(
        [*compiler, *flags, "-o", str(target), str(source), "-lm"], check=True, capture_output=True, text=True
    )
    return target


def glibc_versions(library: object) -> tuple[set[str], tuple[int, ...]]:
    """The GLIBC_ symbol versions a LIEF-parsed ELF `library` requires, and the newest of them."""
    versions = {
        aux.name
        for requirement in library.symbols_version_requirement
        for aux in requirement.get_auxiliary_symbols()
        if aux.name.startswith("GLIBC_")
    }
    newest = max((tuple(int(n) for n in v.removeprefix("GLIBC_").split(".")) for v in versions), default=())
    return versions, newest


def outputs(stdout: str) -> list[tuple[str, int, list[float]]]:
    """The driver's printed rows: tag, step and the outputs' values."""
    rows = []
    for line in stdout.replace("\r", "").splitlines():
        tag, k, *values = line.split()
        rows.append((tag, int(k), [float(v) for v in values]))
    return rows


def assert_same_outputs(expected_stdout: str, got_stdout: str, n_out: int, what: str) -> None:
    """Both runs printed 2001 rows of outputs and 4 of directional derivatives, equal to `RELATIVE` of each output's
    peak."""
    expected, got = outputs(expected_stdout), outputs(got_stdout)
    assert len(expected) == 2005 and [row[:2] for row in got] == [row[:2] for row in expected]
    assert sum(row[0] == "derivative" for row in expected) == 4
    want = np.array([row[2] for row in expected])
    have = np.array([row[2] for row in got])
    assert want.shape == have.shape == (2005, n_out)
    relative = np.max(np.abs(have - want), axis=0) / np.max(np.abs(want), axis=0)
    assert np.all(relative <= RELATIVE), f"{what}, largest difference / peak per output: {relative}"
