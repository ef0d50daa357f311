"""Fixtures of the FMU tests: the test graphs saved to ONNX files and FMUs built from them (once per session)."""

from __future__ import annotations

import sys
from pathlib import Path

import onnx
import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the test modules import the helpers beside this file
from native_fmu_helpers import ProbeSlave, delay_step_graph, generic_graph  # noqa: E402
from pythonfmu_helpers import build, delay_damper_graph  # noqa: E402


@pytest.fixture(scope="session")
def delay_onnx(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("graphs") / "damper.onnx"
    onnx.save(delay_step_graph(), str(path))
    return path


@pytest.fixture(scope="session")
def generic_onnx(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("graphs") / "other.onnx"
    onnx.save(generic_graph(), str(path))
    return path


@pytest.fixture(scope="session")
def delay_fmus(tmp_path_factory: pytest.TempPathFactory, delay_onnx: Path) -> dict[int, Path]:
    """The damper graph built as a native FMU for FMI 2 and FMI 3 (built once per session), for every platform a
    compiler here builds (what a default build carries without `$NNFMU_PLATFORMS`, tests/conftest.py)."""
    from nnfmu.fmu.build import build_fmu
    from nnfmu.fmu.native import toolchain
    from nnfmu.fmu.options import BuildOptions

    every = tuple(p.name for p in toolchain.PLATFORMS if toolchain.candidates(p))
    out = tmp_path_factory.mktemp("fmus")
    return {
        v: build_fmu(delay_onnx, BuildOptions(out=out / f"damper{v}.fmu", fmi_version=v, platforms=every))
        for v in (2, 3)
    }


@pytest.fixture(scope="session")
def filtered_fmus(tmp_path_factory: pytest.TempPathFactory, delay_onnx: Path) -> dict[int, Path]:
    """The damper graph built with the thesis's 100 Hz output filter as its start value, FMI 2 and FMI 3."""
    from nnfmu.fmu.build import build_fmu
    from nnfmu.fmu.options import BuildOptions

    out = tmp_path_factory.mktemp("filtered")
    return {
        v: build_fmu(delay_onnx, BuildOptions(out=out / f"damper{v}.fmu", fmi_version=v, filter_cutoff=100.0))
        for v in (2, 3)
    }


@pytest.fixture(scope="session")
def pythonfmu_dampers(tmp_path_factory: pytest.TempPathFactory) -> dict[int, tuple[Path, Path]]:
    """The pythonfmu damper graph (seed 0) built by the pythonfmu backend for FMI 2 and FMI 3: (onnx, fmu) each."""
    return {
        v: build(tmp_path_factory.mktemp(f"damper{v}"), delay_damper_graph(seed=0), "damper", fmi_version=v)
        for v in (2, 3)
    }


@pytest.fixture
def open_fmu():
    """Factory: open_fmu(path, name=...) -> ProbeSlave; instances are freed after the test."""
    opened: list[ProbeSlave] = []

    def factory(path: Path, name: str = "instance", logging_on: bool = True) -> ProbeSlave:
        slave = ProbeSlave(path, name, logging_on)
        opened.append(slave)
        return slave

    yield factory
    for slave in opened:
        slave.close()
