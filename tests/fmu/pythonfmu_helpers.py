"""Shared by the pythonfmu backend's FMI 2 and FMI 3 tests: a delay-line damper graph, its onnxruntime reference
with the FMU semantics of docs/architecture.md, an instance of its FMU in fmpy, the model description the native
backend renders for the same graph, and unzipping an FMU per instance."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
from fmpy import extract
from onnx import TensorProto, helper, numpy_helper

from nnfmu.component import Component, Port, StatePort
from nnfmu.cosim.slave import FmuSlave
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.model_description import FmuIdentity, ModelDescriptionView, render_model_description, tensor_dependencies
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.variables import fmu_variables

T = 1e-3  # sample period of the test graphs [s]
VMAX = 1.0  # training envelope of the velocity input: [-VMAX, VMAX] m/s
WARNING, DISCARD, ERROR = 1, 2, 3  # the fmi2Status and fmi3Status values the tests look for (the same in both)


def delay_damper_graph(seed: int) -> onnx.ModelProto:
    """velocity [m/s] and a 2-sample delay line -> Gemm -> Tanh -> MatMul -> force [N]; state_next shifts the line."""
    rng = np.random.default_rng(seed)
    inits = [
        numpy_helper.from_array(rng.normal(size=(3, 4)), "W1"),
        numpy_helper.from_array(rng.normal(size=4), "b1"),
        numpy_helper.from_array(100.0 * rng.normal(size=(4, 1)), "W2"),
        numpy_helper.from_array(np.array([0]), "first"),
        numpy_helper.from_array(np.array([1]), "second"),
        numpy_helper.from_array(np.array([1, 3]), "row"),
        numpy_helper.from_array(np.array([1]), "one"),
    ]
    nodes = [
        helper.make_node("Concat", ["velocity", "state"], ["features"], axis=0),
        helper.make_node("Reshape", ["features", "row"], ["x"]),
        helper.make_node("Gemm", ["x", "W1", "b1"], ["z"]),
        helper.make_node("Tanh", ["z"], ["h"]),
        helper.make_node("MatMul", ["h", "W2"], ["f"]),
        helper.make_node("Reshape", ["f", "one"], ["force"]),
        helper.make_node("Slice", ["state", "first", "second"], ["older"]),
        helper.make_node("Concat", ["velocity", "older"], ["state_next"], axis=0),
    ]

    def vector(name: str, n: int) -> onnx.ValueInfoProto:
        return helper.make_tensor_value_info(name, TensorProto.DOUBLE, [n])

    graph = helper.make_graph(
        nodes,
        f"damper{seed}",
        [vector("velocity", 1), vector("state", 2)],
        [vector("force", 1), vector("state_next", 2)],
        inits,
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=9)
    Component(
        name="damper",
        inputs=[Port("velocity", "m/s", "damper velocity", min=-VMAX, max=VMAX)],
        outputs=[Port("force", "N", "damper force")],
        states=[StatePort("state", "state_next", (0.0, 0.0), "velocity delayed by 1 and 2 samples [m/s]")],
        sample_period=T,
        description=f"test damper {seed}",
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model


def build(tmp_path: Path, model: onnx.ModelProto, stem: str, fmi_version: int = 2) -> tuple[Path, Path]:
    """Save `model` and build its pythonfmu FMU for `fmi_version`; return (onnx path, fmu path)."""
    onnx_path = tmp_path / f"{stem}.onnx"
    onnx.save(model, str(onnx_path))
    options = BuildOptions(out=tmp_path / f"{stem}.fmu", backend="pythonfmu", fmi_version=fmi_version)
    return onnx_path, build_fmu(onnx_path, options)


def unzip(fmu: Path) -> str:
    """Extract `fmu` into a fresh folder beside it (inside the test's tmp_path), as a master does per instance."""
    return extract(str(fmu), unzipdir=tempfile.mkdtemp(dir=fmu.resolve().parent))


def view_of(onnx_path: Path, fmi_version: int, component: Component | None = None) -> ModelDescriptionView:
    """What the builder describes for the graph at `onnx_path` (described by `component`, default its own)."""
    model = onnx.load(str(onnx_path))
    component = component or Component.from_onnx(model)
    identity = FmuIdentity(component.name, component.name, "{00000000-0000-0000-0000-000000000000}", fmi_version)
    return ModelDescriptionView(
        identity, component, fmu_variables(component), tensor_dependencies(model), source_files=["graph.c"]
    )  # FMI 2 lists the C sources; any name will do here


def native_description(onnx_path: Path, folder: Path, fmi_version: int = 3) -> Path:
    """The modelDescription.xml the native backend renders for `fmi_version` from the same graph, in `folder`."""
    folder.mkdir()
    (folder / "modelDescription.xml").write_text(
        render_model_description(view_of(onnx_path, fmi_version)), encoding="utf-8"
    )
    return folder


class Reference:
    """The FMU semantics of docs/architecture.md written out directly on an onnxruntime session."""

    def __init__(self, onnx_path: Path, cutoff: float = 0.0, gain: float = 1.0, velocity: float = 0.0):
        self.session = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
        self.state = np.zeros(2)
        self.cutoff, self.gain = cutoff, gain
        self.k = 0
        self.y = gain * self._sample(velocity)

    def _sample(self, velocity: float) -> float:
        force, self.state = self.session.run(None, {"velocity": np.array([velocity]), "state": self.state})
        return float(force[0])

    def step(self, t: float, h: float, velocity: float) -> float:
        """Advance to t + h, with t counted from the start time."""
        while (self.k + 1) * T <= t + h + 1e-6 * T:
            self.k += 1
            u = self.gain * self._sample(velocity)
            a = 1.0 - math.exp(-2.0 * math.pi * self.cutoff * T) if self.cutoff > 0 else 1.0
            self.y += a * (u - self.y)
        return self.y


class Instance(FmuSlave):
    """The package's FmuSlave on a damper FMU of either FMI version, initialised with the given parameters."""

    def __init__(
        self,
        fmu: Path,
        name: str,
        cutoff: float = 0.0,
        gain: float = 1.0,
        velocity: float = 0.0,
        start: float = 0.0,
        logging_on: bool = True,
    ):
        super().__init__(fmu, name, logging_on)
        self.initialise(cutoff, gain, velocity, start)

    def initialise(self, cutoff: float, gain: float, velocity: float, start: float = 0.0) -> None:
        self.enter_initialization(start)
        self.set_real(["filter_cutoff", "output_gain", "velocity"], [cutoff, gain, velocity])
        self.exit_initialization()

    def step(self, t: float, h: float, velocity: float) -> float:
        """Set the velocity [m/s], step from t by h and return the force [N]."""
        self.set_real(["velocity"], [velocity])
        self.do_step(t, h)
        return self.force()

    def force(self) -> float:
        return float(self.get_real(["force"])[0])

    def logged(self, status: int) -> list[str]:
        """The messages logged with `status`."""
        return [m for s, _, m in self.messages if s == status]

    def serialised_state(self) -> object:
        """The current FMU state, taken through serialising and deserialising it (to free with `free_state`)."""
        if self.fmi_version == 2:
            return self.fmu.deSerializeFMUstate(self.fmu.serializeFMUstate(self.fmu.getFMUstate()))
        return self.fmu.deserializeFMUState(self.fmu.serializeFMUState(self.fmu.getFMUState()))
