"""Helpers for the native FMU tests: small ONNX step graphs (onnx.helper, no torch), their onnxruntime reference
of the FMU semantics, and the package's fmpy wrapper with the tests' conveniences."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper

from nnfmu.component import Component, Port, StatePort
from nnfmu.cosim.slave import FmuSlave

SAMPLE_PERIOD = 1e-3  # [s]
OPSET = 17
IR_VERSION = 8  # onnxruntime reads IR versions up to 10 or so; the onnx default may be newer


def _double(name: str, shape: list[int]) -> onnx.ValueInfoProto:
    return helper.make_tensor_value_info(name, TensorProto.DOUBLE, shape)


def _const(name: str, array: np.ndarray) -> onnx.TensorProto:
    return numpy_helper.from_array(np.asarray(array), name)


def delay_step_graph() -> onnx.ModelProto:
    """A damper-like step graph: force and torque from velocity, displacement and the last two velocities.

    state = [v_{k-1}, v_{k-2}]; state_next = [v_k, v_{k-1}]; hidden = tanh(W1 [v, x, state] + b1);
    [force, torque] = W2 hidden + b2 (float64 throughout).
    """
    rng = np.random.default_rng(7)
    w1 = rng.normal(size=(4, 5))
    b1 = rng.normal(size=(5,))
    w2 = rng.normal(size=(5, 2)) * 100.0
    b2 = rng.normal(size=(2,))
    nodes = [
        helper.make_node("Concat", ["velocity", "displacement", "state"], ["features"], axis=0, name="features"),
        helper.make_node("Reshape", ["features", "row_shape"], ["row"], name="as_row"),
        helper.make_node("Gemm", ["row", "w1", "b1"], ["pre"], name="layer1"),
        helper.make_node("Tanh", ["pre"], ["hidden"], name="tanh1"),
        helper.make_node("Gemm", ["hidden", "w2", "b2"], ["out_row"], name="layer2"),
        helper.make_node("Reshape", ["out_row", "flat_shape"], ["out"], name="flatten"),
        helper.make_node("Slice", ["out", "zero", "one", "axis0"], ["force"], name="take_force"),
        helper.make_node("Slice", ["out", "one", "two", "axis0"], ["torque"], name="take_torque"),
        helper.make_node("Slice", ["state", "zero", "one", "axis0"], ["older"], name="shift"),
        helper.make_node("Concat", ["velocity", "older"], ["state_next"], axis=0, name="push"),
    ]
    initializers = [
        _const("w1", w1),
        _const("b1", b1),
        _const("w2", w2),
        _const("b2", b2),
        _const("row_shape", np.array([1, 4], dtype=np.int64)),
        _const("flat_shape", np.array([2], dtype=np.int64)),
        _const("zero", np.array([0], dtype=np.int64)),
        _const("one", np.array([1], dtype=np.int64)),
        _const("two", np.array([2], dtype=np.int64)),
        _const("axis0", np.array([0], dtype=np.int64)),
    ]
    graph = helper.make_graph(
        nodes,
        "damper_step",
        [_double("velocity", [1]), _double("displacement", [1]), _double("state", [2])],
        [_double("force", [1]), _double("torque", [1]), _double("state_next", [2])],
        initializers,
    )
    model = helper.make_model(
        graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="nnfmu-tests", ir_version=IR_VERSION
    )
    component = Component(
        name="damper",
        inputs=[
            Port("velocity", "m/s", "piston velocity", min=-1.0, max=1.0),
            Port("displacement", "m", "piston displacement", min=-0.1, max=0.1),
        ],
        outputs=[Port("force", "N", "damper force"), Port("torque", "N.m", "reaction torque")],
        states=[StatePort("state", "state_next", (0.0, 0.0), "last two velocities [m/s]")],
        sample_period=SAMPLE_PERIOD,
        description="test damper: delay line + Gemm + Tanh",
    )
    component.attach_to(model)
    onnx.checker.check_model(model)
    return model


def generic_graph(input_name: str = "x", output_name: str = "y") -> onnx.ModelProto:
    """Another tool's graph without nnfmu metadata: y[2] = tanh(x[3] W), plus a second output z = sum of x."""
    w = np.array([[0.5, -1.0], [2.0, 0.25], [-0.75, 1.5]])
    nodes = [
        helper.make_node("MatMul", [input_name, "w"], ["pre"], name="matmul"),
        helper.make_node("Tanh", ["pre"], [output_name], name="tanh"),
        helper.make_node("Reshape", [input_name, "row_shape"], ["x_row"], name="row"),
        helper.make_node("Gemm", ["x_row", "ones"], ["z_row"], name="sum"),
        helper.make_node("Reshape", ["z_row", "one_shape"], ["z"], name="flat"),
    ]
    graph = helper.make_graph(
        nodes,
        "other_tool",
        [_double(input_name, [3])],
        [_double(output_name, [2]), _double("z", [1])],
        [
            _const("w", w),
            _const("ones", np.ones((3, 1))),
            _const("row_shape", np.array([1, 3], dtype=np.int64)),
            _const("one_shape", np.array([1], dtype=np.int64)),
        ],
    )
    model = helper.make_model(
        graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="other-tool", ir_version=IR_VERSION
    )
    onnx.checker.check_model(model)
    return model


def hostile_graph() -> onnx.ModelProto:
    """A graph from another tool whose tensor names are hostile to C and XML and clash after sanitising."""
    names = ['a"b', "c<d&e", "f*/g", "line\nbreak", "time", "a_b"]
    outputs = ["extrapolating", "out%s'"]
    nodes = [
        helper.make_node("Add", [names[0], names[1]], ["s1"], name="add1"),
        helper.make_node("Add", ["s1", names[2]], ["s2"], name="add2"),
        helper.make_node("Add", [names[3], names[4]], ["s3"], name="add3"),
        helper.make_node("Mul", ["s2", names[5]], [outputs[0]], name="mul"),
        helper.make_node("Tanh", ["s3"], [outputs[1]], name="tanh"),
    ]
    graph = helper.make_graph(
        nodes,
        "hostile */ <graph>",
        [helper.make_tensor_value_info(n, TensorProto.DOUBLE, [1]) for n in names],
        [helper.make_tensor_value_info(n, TensorProto.DOUBLE, [1]) for n in outputs],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    model.doc_string = 'doc with "quotes", <tags>, */ and a\nnewline\x01'
    return model


@dataclass
class Reference:
    """The FMU semantics of docs/architecture.md computed with onnxruntime, one sample at a time."""

    model: onnx.ModelProto

    def __post_init__(self) -> None:
        self.session = ort.InferenceSession(self.model.SerializeToString(), providers=["CPUExecutionProvider"])
        self.component = Component.from_onnx(self.model)

    def step(self, inputs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        """One sample: port inputs (n_in,) and state -> port outputs (n_out,) and next state."""
        return self.evaluate(inputs, state)

    def evaluate(self, inputs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        """One evaluation of the graph (a sample, or a communication point between samples)."""
        feeds: dict[str, np.ndarray] = {}
        for node_input in self.session.get_inputs():
            shape = [d if isinstance(d, int) else 1 for d in node_input.shape]
            feeds[node_input.name] = np.zeros(int(np.prod(shape)))
        for value, port in zip(inputs, self.component.inputs):
            feeds[port.tensor][port.index] = value
        if self.component.states:
            feeds[self.component.states[0].input][:] = state
        shapes = {i.name: [d if isinstance(d, int) else 1 for d in i.shape] for i in self.session.get_inputs()}
        feeds = {k: v.reshape(shapes[k]) for k, v in feeds.items()}
        names = [o.name for o in self.session.get_outputs()]
        results = dict(zip(names, self.session.run(None, feeds)))
        outputs = np.array([np.ravel(results[p.tensor])[p.index] for p in self.component.outputs])
        next_state = np.ravel(results[self.component.states[0].output]).copy() if self.component.states else None
        return outputs, next_state

    def simulate(self, inputs: np.ndarray, step: float, cutoff: float = 0.0, gain: float = 1.0) -> np.ndarray:
        """Outputs after each communication step when `inputs[n]` is set before step n (n = 0 at initialisation).

        Samples k T reached by a step are evaluated with the inputs set before it; a step ending a fraction alpha of
        T after the latest sample evaluates the graph once more with the state interpolated between the state that
        sample was evaluated from and the state after it (docs/fmu.md). The output filter runs over the time since
        the outputs were last evaluated. Returns shape (n_steps + 1, n_out): row 0 after initialisation, row n after
        doStep n.
        """
        period = self.component.sample_period

        def filtered(y: np.ndarray, raw: np.ndarray, dt: float) -> np.ndarray:
            a = 1.0 if cutoff <= 0 else 1.0 - np.exp(-2 * np.pi * cutoff * dt)
            return y + a * (gain * raw - y)

        state = np.array(self.component.states[0].initial) if self.component.states else None
        raw, after = self.step(inputs[0], state)
        before, state = state, after
        y = gain * raw
        rows = [y.copy()]
        k, evaluated_at = 1, 0.0
        for n in range(1, len(inputs)):
            t, end = (n - 1) * step, n * step
            if period is None:
                raw, state = self.step(inputs[n], state)
                y = filtered(y, raw, step)
            else:
                while k * period <= end + 1e-6 * period:
                    assert k * period > t - 1e-6 * period
                    raw, after = self.step(inputs[n], state)
                    before, state = state, after
                    y = filtered(y, raw, k * period - evaluated_at)
                    evaluated_at = k * period
                    k += 1
                alpha = (end - (k - 1) * period) / period
                if alpha > 1e-6:
                    between = None if state is None else (1.0 - alpha) * before + alpha * state
                    raw, _ = self.evaluate(inputs[n], between)
                    y = filtered(y, raw, end - evaluated_at)
                    evaluated_at = end
            rows.append(y.copy())
        return np.array(rows)


class ProbeSlave(FmuSlave):
    """The package's FmuSlave with the tests' conveniences: the port inputs and real outputs by name, initialising
    with inputs and parameters, and whole runs as rows comparable with Reference.simulate."""

    def __init__(self, path: Path, name: str = "instance", logging_on: bool = True) -> None:
        super().__init__(path, name, logging_on)
        self.inputs = self.names("input")
        self.outputs = [n for n in self.names("output") if self.variables[n].type != "Boolean"]

    def initialize(self, inputs, start: float = 0.0, parameters: dict[str, float] | None = None) -> None:
        self.enter_initialization(start)
        if parameters:
            self.set_real(list(parameters), list(parameters.values()))
        self.set_real(self.inputs, inputs)
        self.exit_initialization()

    def outputs_now(self) -> np.ndarray:
        return self.get_real(self.outputs)

    def extrapolating(self) -> bool:
        return self.get_boolean(["extrapolating"])[0]

    def simulate(self, inputs: np.ndarray, h: float, start: float = 0.0, parameters=None) -> np.ndarray:
        """Rows like Reference.simulate: inputs[n] set before step n; row n read after it."""
        self.initialize(inputs[0], start, parameters)
        rows = [self.outputs_now()]
        for n in range(1, len(inputs)):
            self.set_real(self.inputs, inputs[n])
            self.do_step(start + (n - 1) * h, h)
            rows.append(self.outputs_now())
        return np.array(rows)
