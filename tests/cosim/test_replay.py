"""Replay: a native FMU driven by measured inputs reproduces the network sample by sample (vs onnxruntime)."""

from __future__ import annotations

import gc
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

from nnfmu.cosim import slave as slave_module
from nnfmu.cosim.replay import ReplayError, ReplaySettings, replay_fmu
from nnfmu.cosim.slave import FmuSlave
from nnfmu.data.measurement import Measurement
from nnfmu.export import export_onnx, run_step_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.models.features import FeatureSpec, Tap
from nnfmu.models.networks import MLP
from nnfmu.models.scaling import MinMaxScaler
from nnfmu.models.trained import TrainedModel

T = 1e-3
SPEC = FeatureSpec(taps=(Tap("velocity", (0, 1, 2)), Tap("displacement", (0,))), output="force")


def _measurement(n: int, seed: int, dt: float = T) -> Measurement:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    x = 0.03 * np.sin(2 * np.pi * 1.3 * t) + 0.002 * rng.normal(size=n)
    v = 0.6 * np.sin(2 * np.pi * 4.1 * t + 0.4) + 0.05 * rng.normal(size=n)
    return Measurement(
        time=t,
        channels={"displacement": x, "velocity": v, "force": np.zeros(n)},
        units={"displacement": "m", "velocity": "m/s", "force": "N"},
        source=f"synthetic-{seed}",
    )


@pytest.fixture(scope="module")
def damper_fmu(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    torch.manual_seed(3)
    network = MLP(SPEC.n_features, 5)
    train = _measurement(800, 1)
    model = TrainedModel(
        spec=SPEC,
        network=network,
        feature_scaler=MinMaxScaler.fit(SPEC.features(train.channels, T)),
        target_scaler=MinMaxScaler.fit(np.array([-1500.0, 3000.0])),
        sample_period=T,
        units=dict(train.units),
        envelope={c: (float(train[c].min()), float(train[c].max())) for c in SPEC.channels},
    )
    folder = tmp_path_factory.mktemp("replay")
    onnx_path = export_onnx(model, folder / "damper.onnx").path
    return onnx_path, build_fmu(onnx_path, BuildOptions(out=folder / "damper.fmu"))


def test_replay_equals_onnxruntime_sample_by_sample(damper_fmu: tuple[Path, Path]) -> None:
    onnx_path, fmu_path = damper_fmu
    data = _measurement(3000, 2)
    replayed = replay_fmu(fmu_path, data)
    expected = run_step_graph(onnx_path, {c: data[c] for c in SPEC.channels})["force"]
    assert replayed.units["force"] == "N"
    np.testing.assert_allclose(replayed["force"], expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_fmi3_replay_equals_onnxruntime_and_the_by_name_calls(damper_fmu: tuple[Path, Path], tmp_path: Path) -> None:
    onnx_path, _ = damper_fmu
    fmu3 = build_fmu(onnx_path, BuildOptions(out=tmp_path / "damper3.fmu", fmi_version=3))
    data = _measurement(500, 4)
    replayed = replay_fmu(fmu3, data)["force"]
    expected = run_step_graph(onnx_path, {c: data[c] for c in SPEC.channels})["force"]
    np.testing.assert_allclose(replayed, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    with FmuSlave(fmu3) as slave:  # the buffered calls set and read what set_real/get_real by name do
        inputs = slave.names("input")
        io = slave.real_io(inputs, ["force"])
        slave.enter_initialization(0.0)
        io.set(np.array([data[c][0] for c in inputs]))
        slave.exit_initialization()
        assert io.get()[0] == slave.get_real(["force"])[0] == replayed[0]


def test_replay_with_output_filter_differs_from_raw(damper_fmu: tuple[Path, Path]) -> None:
    _, fmu_path = damper_fmu
    data = _measurement(500, 4)
    raw = replay_fmu(fmu_path, data)["force"]
    filtered = replay_fmu(fmu_path, data, ReplaySettings(filter_cutoff=20.0))["force"]
    a = 1 - np.exp(-2 * np.pi * 20.0 * T)
    expected = np.empty_like(raw)
    expected[0] = raw[0]
    for k in range(1, len(raw)):
        expected[k] = expected[k - 1] + a * (raw[k] - expected[k - 1])
    np.testing.assert_allclose(filtered, expected, rtol=1e-9, atol=1e-9)


def test_replay_refuses_missing_channel_and_other_sample_rate(damper_fmu: tuple[Path, Path]) -> None:
    _, fmu_path = damper_fmu
    data = _measurement(100, 5)
    del data.channels["displacement"]
    with pytest.raises(ReplayError, match="'displacement'"):
        replay_fmu(fmu_path, data)
    with pytest.raises(ReplayError, match="sample period"):
        replay_fmu(fmu_path, _measurement(100, 5, dt=2e-3))


def test_an_fmu_that_cannot_start_leaves_no_extracted_files(
    damper_fmu: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    broken = tmp_path / "no-binaries.fmu"  # a valid description whose shared library is missing
    with zipfile.ZipFile(damper_fmu[1]) as source, zipfile.ZipFile(broken, "w") as target:
        for item in source.infolist():
            if not item.filename.startswith("binaries/"):
                target.writestr(item, source.read(item))
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    with pytest.raises(Exception):
        FmuSlave(broken)
    assert list(scratch.iterdir()) == []
    with FmuSlave(damper_fmu[1]):  # the same start with its binaries extracts into the scratch folder
        assert len(list(scratch.iterdir())) == 1
    assert list(scratch.iterdir()) == []


def test_a_slave_its_caller_never_closes_leaves_no_extracted_files(
    damper_fmu: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    slave = FmuSlave(damper_fmu[1])
    key = slave._key
    assert len(list(scratch.iterdir())) == 1 and key in slave_module._FMI2_SINKS
    del slave
    gc.collect()
    assert list(scratch.iterdir()) == []
    assert key not in slave_module._FMI2_SINKS


def _stepped(slave: FmuSlave, value: float) -> np.ndarray:
    """The slave's Real outputs after one 1 ms step with every input at `value` from rest."""
    inputs = slave.names("input")
    slave.enter_initialization(0.0)
    slave.exit_initialization()
    slave.set_real(inputs, [value] * len(inputs))
    slave.do_step(0.0, 1e-3)
    return slave.get_real([n for n in slave.names("output") if slave.variables[n].type in ("Real", "Float64")])


def test_instances_of_one_fmu_share_its_extracted_folder_until_the_last_closes(
    damper_fmu: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One folder, one loaded library, two independent instances; an FMU that may be instantiated only once per
    process gets a folder (and so a library) per instance."""
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    first, second = FmuSlave(damper_fmu[1], "first"), FmuSlave(damper_fmu[1], "second")
    assert first.directory == second.directory and len(list(scratch.iterdir())) == 1
    moved, resting = _stepped(first, 0.3), _stepped(second, 0.0)
    assert np.any(moved != resting)  # each instance its own state
    first.close()
    assert second.directory.is_dir()
    second.close()
    assert list(scratch.iterdir()) == []
    once = tmp_path / "once.fmu"
    with zipfile.ZipFile(damper_fmu[1]) as source, zipfile.ZipFile(once, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b"<CoSimulation", b'<CoSimulation canBeInstantiatedOnlyOncePerProcess="true"', 1)
            target.writestr(item, data)
    with FmuSlave(once, "a") as a, FmuSlave(once, "b") as b:
        assert a.directory != b.directory and len(list(scratch.iterdir())) == 2
    assert list(scratch.iterdir()) == []
