"""A small co-simulation system built by hand for the master's tests: a linear quarter car and a linear damper.

The quarter car (the vehicle package's model, damper force as input) is discretised exactly for a zero-order hold
and written as an ONNX step graph with state: sample k maps the state x_{k-1} and the inputs held over the step
ending at t_k to x_k = Ad x_{k-1} + Bd u + fd and the outputs y_k = C x_k + D u + e. The damper is F = c v.
The exact coupled reference closes the damper inside the matrix (A + c B_F C_v) and is discretised the same way,
so against it the co-simulation error is the coupling error alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper
from scipy.linalg import expm

from nnfmu.component import Component, Port, StatePort
from nnfmu.cosim.ssp import connect_by_name, write_ssd
from nnfmu.data import Measurement
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.dynamics import QuarterCarParameters, build_quarter_car

OPSET = 17
IR_VERSION = 8
OUTPUTS = ("damper_displacement", "damper_velocity", "body_displacement", "spindle_displacement")
DAMPING = 2400.0  # [N.s/m]
DRIVE = ("actuator_displacement", "actuator_velocity")  # the hand-made plant's drive inputs; the test drive's channels
VEHICLE_DRIVE = ("actuator_fl_displacement", "actuator_fl_velocity")  # the quarter car's, whose matrices it takes
NO_FILTER = {"filter_cutoff": 0.0}
# The basic schemes these tests measure, named in full (the master's defaults are the one-pass accurate scheme):
# plain Gauss-Seidel with the components first, and libcosim's algorithm (Jacobi, nothing estimated or refreshed).
BASIC = {"order": "components-first", "extrapolation": "none"}
LIBCOSIM = {"scheme": "jacobi", "extrapolation": "none", "refresh": False}


def _double(name: str, shape: list[int]) -> onnx.ValueInfoProto:
    return helper.make_tensor_value_info(name, TensorProto.DOUBLE, shape)


def _const(name: str, array: np.ndarray) -> onnx.TensorProto:
    return numpy_helper.from_array(np.asarray(array), name)


@dataclass(frozen=True)
class LinearPlant:
    """x' = A x + B u + f, y = C x + D u + e with named inputs and outputs and units."""

    A: np.ndarray
    B: np.ndarray
    f: np.ndarray
    C: np.ndarray
    D: np.ndarray
    e: np.ndarray
    inputs: tuple[tuple[str, str], ...]
    outputs: tuple[tuple[str, str], ...]

    def discretise(self, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Ad, Bd, fd) of the exact zero-order-hold step h."""
        nx, nu = self.B.shape
        aug = np.zeros((nx + nu + 1, nx + nu + 1))
        aug[:nx, :nx] = self.A
        aug[:nx, nx : nx + nu] = self.B
        aug[:nx, -1] = self.f
        e = expm(aug * h)
        return e[:nx, :nx], e[:nx, nx : nx + nu], e[:nx, -1]

    def simulate(self, held: np.ndarray, h: float) -> np.ndarray:
        """Outputs at t_0..t_N from x_0 = 0, input row n held over [t_n, t_{n+1}] (shape (N, nu)); D u uses row n-1."""
        ad, bd, fd = self.discretise(h)
        x = np.zeros(self.A.shape[0])
        rows = [self.C @ x + self.D @ held[0] + self.e]
        for u in held:
            x = ad @ x + bd @ u + fd
            rows.append(self.C @ x + self.D @ u + self.e)
        return np.array(rows)


def quarter_cars() -> tuple[LinearPlant, LinearPlant]:
    """(quarter car with the damper force as input, the same closed with F = c v inside the matrix)."""
    vehicle = build_quarter_car(QuarterCarParameters.load())
    rows = [vehicle.output_index(n) for n in OUTPUTS]
    cols = [vehicle.input_index(n) for n in (*VEHICLE_DRIVE, "damper_force")]
    a, b, c, d = vehicle.A, vehicle.B[:, cols], vehicle.C[rows], vehicle.D[rows][:, cols]
    units = {p.name: p.unit for p in vehicle.outputs + vehicle.inputs}
    open_loop = LinearPlant(
        a,
        b,
        vehicle.f,
        c,
        d,
        vehicle.e[rows],
        tuple((n, units[v]) for n, v in zip((*DRIVE, "damper_force"), (*VEHICLE_DRIVE, "damper_force"))),
        tuple((n, units[n]) for n in OUTPUTS),
    )
    assert not np.any(d[:, 2]), "the compared outputs do not feed through the damper force"
    c_v = vehicle.C[vehicle.output_index("damper_velocity")]
    closed = LinearPlant(
        a + DAMPING * np.outer(b[:, 2], c_v),
        b[:, :2],
        vehicle.f,
        c,
        d[:, :2],
        vehicle.e[rows],
        open_loop.inputs[:2],
        open_loop.outputs,
    )
    return open_loop, closed


def plant_step_graph(plant: LinearPlant, h: float, name: str) -> onnx.ModelProto:
    """The plant's exact zero-order-hold step as an ONNX step graph with state (see the module docstring)."""
    ad, bd, fd = plant.discretise(h)
    nx, nu = bd.shape
    ny = plant.C.shape[0]
    in_names = [n for n, _ in plant.inputs]
    nodes = [
        helper.make_node("Concat", in_names, ["u"], axis=0, name="inputs"),
        helper.make_node("Concat", ["x", "u"], ["xu"], axis=0, name="state_and_inputs"),
        helper.make_node("Reshape", ["xu", "xu_shape"], ["xu_row"], name="xu_row"),
        helper.make_node("Gemm", ["xu_row", "step_matrix", "fd"], ["x_next_row"], name="exact_step"),
        helper.make_node("Reshape", ["x_next_row", "x_shape"], ["x_next"], name="x_next"),
        helper.make_node("Concat", ["x_next", "u"], ["xu_next"], axis=0, name="new_state_and_inputs"),
        helper.make_node("Reshape", ["xu_next", "xu_shape"], ["xu_next_row"], name="xu_next_row"),
        helper.make_node("Gemm", ["xu_next_row", "output_matrix", "e"], ["y_row"], name="outputs"),
        helper.make_node("Reshape", ["y_row", "y_shape"], ["y"], name="y"),
    ]
    for j, (out, _) in enumerate(plant.outputs):
        nodes.append(helper.make_node("Slice", ["y", f"start{j}", f"end{j}", "axis0"], [out], name=f"take_{out}"))
    initializers = [
        _const("step_matrix", np.hstack([ad, bd]).T.copy()),
        _const("fd", fd),
        _const("output_matrix", np.hstack([plant.C, plant.D]).T.copy()),
        _const("e", plant.e),
        _const("xu_shape", np.array([1, nx + nu], dtype=np.int64)),
        _const("x_shape", np.array([nx], dtype=np.int64)),
        _const("y_shape", np.array([ny], dtype=np.int64)),
        _const("axis0", np.array([0], dtype=np.int64)),
    ]
    for j in range(ny):
        initializers += [
            _const(f"start{j}", np.array([j], dtype=np.int64)),
            _const(f"end{j}", np.array([j + 1], dtype=np.int64)),
        ]
    graph = helper.make_graph(
        nodes,
        name,
        [_double(n, [1]) for n in in_names] + [_double("x", [nx])],
        [_double(n, [1]) for n, _ in plant.outputs] + [_double("x_next", [nx])],
        initializers,
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)], ir_version=IR_VERSION)
    Component(
        name=name,
        inputs=[Port(n, u) for n, u in plant.inputs],
        outputs=[Port(n, u) for n, u in plant.outputs],
        states=[StatePort("x", "x_next", tuple([0.0] * nx), "state at the latest sample")],
        sample_period=h,
        description="exact zero-order-hold step of a linear quarter car",
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model


def damper_graph() -> onnx.ModelProto:
    """A stateless linear damper F = c v (no sample period: evaluated once per communication step)."""
    return linear_damper_graph(DAMPING)


def build(model: onnx.ModelProto, folder: Path, name: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    onnx_path = folder / f"{name}.onnx"
    onnx.save(model, str(onnx_path))
    return build_fmu(onnx_path, BuildOptions(out=folder / f"{name}.fmu"))


def write_system(folder: Path, h: float, damper_fmu: Path) -> Path:
    """SystemStructure.ssd in `folder` joining a quarter car FMU for step h and the damper FMU, filters off."""
    open_loop, _ = quarter_cars()
    vehicle_fmu = build(plant_step_graph(open_loop, h, "quarter_car"), folder, "quarter_car")
    system = connect_by_name(
        "quarter car with damper",
        ("vehicle", vehicle_fmu),
        {"damper": damper_fmu},
        folder,
        parameters={"vehicle": NO_FILTER, "damper": NO_FILTER},
    )
    return write_ssd(system, folder / "SystemStructure.ssd")


def drive_signal(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Post displacement [m] and velocity [m/s], both zero at t = 0: two raised cosines at 1.5 and 11 Hz."""
    w1, w2 = 2 * np.pi * 1.5, 2 * np.pi * 11.0
    x = 0.02 * (1 - np.cos(w1 * t)) + 0.004 * (1 - np.cos(w2 * t))
    v = 0.02 * w1 * np.sin(w1 * t) + 0.004 * w2 * np.sin(w2 * t)
    return x, v


def drive(duration: float, period: float, corner: str | None = None) -> Measurement:
    """The test drive as the hand-made plant's channels (DRIVE), or as those of the post under `corner` (what the
    vehicle package's quarter car on that corner reads)."""
    t = np.arange(round(duration / period) + 1) * period
    x, v = drive_signal(t)
    names = DRIVE if corner is None else (f"actuator_{corner}_displacement", f"actuator_{corner}_velocity")
    return Measurement(
        time=t, channels=dict(zip(names, (x, v))), units=dict(zip(names, ("m", "m/s"))), source="test drive"
    )


def reference(duration: float, h: float, mean_hold: bool) -> np.ndarray:
    """Exact coupled outputs (OUTPUTS columns) at t_n = n h, drive held at t_n values or at step means."""
    _, closed = quarter_cars()
    x, v = drive_signal(np.arange(round(duration / h) + 1) * h)
    u = np.column_stack([x, v])
    held = 0.5 * (u[:-1] + u[1:]) if mean_hold else u[:-1]
    return closed.simulate(held, h)


def peak_error(result: Measurement, expected: np.ndarray, name: str = "damper_velocity") -> float:
    """Largest deviation of channel `name` from the reference, relative to the reference's peak."""
    column = expected[:, OUTPUTS.index(name)]
    return float(np.max(np.abs(result[name] - column)) / np.max(np.abs(column)))
