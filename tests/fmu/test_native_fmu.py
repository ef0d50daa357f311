"""What only the native backend has: state files that read back in the corners the fuzzer found, build failures of the
C generator and compiler, the exported symbols and the shipped sources. The FMU semantics both backends share are the
contract suite's (test_contract.py)."""

from __future__ import annotations

import subprocess
import zipfile

import onnx
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime
from native_fmu_helpers import SAMPLE_PERIOD
from onnx import helper

from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.options import BuildOptions

T = SAMPLE_PERIOD


def test_a_state_saved_after_setup_experiment_deserialises_and_a_non_finite_start_is_refused(delay_fmus, open_fmu):
    """Found by test_fuzz.py (seed 2): SetupExperiment kept the start time apart from the time, so a state saved
    between it and initialisation failed the FMU's own plausibility check (time != start + elapsed) when read back."""
    slave = open_fmu(delay_fmus[2])
    slave.fmu.setupExperiment(startTime=5.0)
    saved = slave.fmu.getFMUState()
    restored = slave.fmu.deserializeFMUState(slave.fmu.serializeFMUState(saved))
    slave.fmu.setFMUState(restored)
    slave.fmu.freeFMUState(saved)
    slave.fmu.freeFMUState(restored)
    slave.fmu.enterInitializationMode()
    slave.fmu.exitInitializationMode()
    slave.do_step(5.0, T)
    assert slave.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(5.0 + T)
    other = open_fmu(delay_fmus[2], name="other")
    with pytest.raises(FMICallException):
        other.fmu.setupExperiment(startTime=float("nan"))


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_state_saved_after_terminating_a_failed_initialisation_deserialises(delay_fmus, open_fmu, fmi):
    """Found by test_fuzz.py (seed 5497): a failed initialisation leaves no sample done; terminated so, the FMU's
    state failed its own sample-counter check when read back."""
    slave = open_fmu(delay_fmus[fmi])
    slave.enter_initialization(0.0)
    slave.set_real(["output_gain"], [1e308])  # the first sample's outputs overflow: initialisation fails
    with pytest.raises(FMICallException):
        slave.exit_initialization()
    slave.fmu.terminate()
    saved = slave.fmu.getFMUState()
    restored = slave.fmu.deserializeFMUState(slave.fmu.serializeFMUState(saved))
    slave.fmu.setFMUState(restored)
    slave.fmu.freeFMUState(saved)
    slave.fmu.freeFMUState(restored)


def test_unsupported_op_fails_the_build_naming_op_node_and_fallback(tmp_path):
    node = helper.make_node("Einsum", ["x", "x"], ["y"], name="odd_node", equation="i,i->i")
    graph = helper.make_graph(
        [node],
        "g",
        [helper.make_tensor_value_info("x", onnx.TensorProto.DOUBLE, [2])],
        [helper.make_tensor_value_info("y", onnx.TensorProto.DOUBLE, [2])],
    )
    onnx_path = tmp_path / "einsum.onnx"
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8), str(onnx_path))
    out = tmp_path / "out" / "einsum.fmu"
    with pytest.raises(FmuBuildError, match=r"(?s)(?=.*Einsum)(?=.*odd_node).*--backend pythonfmu"):
        build_fmu(onnx_path, BuildOptions(out=out))
    assert not out.exists()
    assert not out.parent.exists() or not any(out.parent.iterdir())


def test_compiler_failure_leaves_no_fmu(delay_onnx, tmp_path, monkeypatch):
    out = tmp_path / "broken.fmu"
    monkeypatch.setenv("CC", "gcc -DNN_N_STATE=")  # a real compiler error in the FMU's sources
    with pytest.raises(FmuBuildError, match="C compiler failed"):
        build_fmu(delay_onnx, BuildOptions(out=out))
    assert list(tmp_path.iterdir()) == []


def test_only_fmi_functions_are_exported(delay_fmus, tmp_path):
    for fmi, path in delay_fmus.items():
        with zipfile.ZipFile(path) as archive:  # this machine's binary, and aarch64-linux's where Zig built one
            binaries = [n for n in archive.namelist() if n.startswith("binaries/") and n.endswith(".so")]
            assert ("binaries/linux64/damper.so" if fmi == 2 else "binaries/x86_64-linux/damper.so") in binaries
            for k, binary in enumerate(binaries):
                target = tmp_path / f"fmu{fmi}-{k}.so"
                target.write_bytes(archive.read(binary))
                listing = subprocess.run(
                    ["nm", "-D", "--defined-only", str(target)], capture_output=True, text=True, check=True
                ).stdout
                symbols = [line.split()[-1] for line in listing.splitlines() if line.split()[1] in "TDBR"]
                assert symbols and all(s.startswith(f"fmi{fmi}") for s in symbols), (binary, symbols)


def test_sources_and_build_description_are_shipped(delay_fmus):
    with zipfile.ZipFile(delay_fmus[2]) as archive:
        names = set(archive.namelist())
        build = archive.read("sources/buildDescription.xml").decode()
    for name in (
        "sources/nn_fmu.c",
        "sources/nn_fmu.h",
        "sources/config.h",
        "sources/graph.c",
        "sources/graph.h",
        "sources/fmi2Functions.c",
        "sources/fmi2Functions.h",
        "sources/buildDescription.xml",
    ):
        assert name in names
    assert 'modelIdentifier="damper"' in build and 'name="graph.c"' in build
    assert not any(n.endswith(".py") for n in names)
    assert [n for n in names if "onnx" in n] == ["extra/org.nnfmu/model.onnx"]  # carried, not run: no onnxruntime
