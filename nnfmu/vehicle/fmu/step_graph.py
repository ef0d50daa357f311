"""The exact discrete step of a vehicle model as an ONNX step graph (float64), ready for the component FMU factory.

One evaluation is one sample k: it advances the state x from sample k-1 to sample k with the inputs linear over that
interval, from their values at sample k-1 (`u_start`) to those at sample k (`u`), and reports the outputs at sample
k, y = C x + D u + Dyn g(x, u) + e. The FMU declares `u_start` as the interval start of `u` (`Component.
interval_starts`), so it interpolates the inputs between samples (docs/fmu.md): a drive file's post motion ramps
between its samples, and the force a component sets at a sample's time is the force there. Graph tensors: state
inputs x (1, nx) and first (1, 1), inputs u and u_start (1, nu); outputs y (1, ny) and the next states x_next,
first_next. `first` is 1 only at sample 0, which reports the initial state without advancing it (x_k = (1 - first)
advanced + first x, exact for first in {0, 1}); it is 0 afterwards.

The linear part advances exactly (first-order hold): x_k = Ad x + Bd0 u_start + Bd1 u + fd. Built-in spline dampers
(forces g) are stepped as `nnfmu.vehicle.dynamics.DiscreteVehicle.step` does: the graph unrolls its predictor-corrector
sub-steps, and evaluates each spline as f0 + s0 (v - v0) + sum_i (s_i - s_{i-1}) Relu(v - v_i), which is its
piecewise-linear table extended linearly beyond the end points. Stabilised force ports hold their deviation from the
reference element, u_start - S x with S x at the sample's start, over the interval (see
`nnfmu.vehicle.dynamics.linear`); a linear vehicle's graph folds S and the held ports into its step matrix, one
product of [x, u_start, u] a sample. Operators: Concat, Gemm, MatMul, Mul, Add, Sub, Relu, Identity (built with the
exporter's GraphBuilder).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import onnx
from onnx import TensorProto, helper

from nnfmu.export.graph import IR_VERSION, OPSET, GraphBuilder
from nnfmu.vehicle.dynamics.builtin_elements import SplineDamper
from nnfmu.vehicle.dynamics.linear import DiscreteVehicle, LinearVehicle
from nnfmu.vehicle.dynamics.port_gains import MIN_DIAGONAL, GainCorrection
from nnfmu.vehicle.fmu.errors import VehicleBuildError

STATE_IN, STATE_OUT, INPUTS, OUTPUTS = "x", "x_next", "u", "y"
INPUTS_START = "u_start"  # the inputs at the previous sample: the start of the interval
FIRST_IN, FIRST_OUT = "first", "first_next"
GAINS, GAINS_START = "port_gains", "port_gains_start"  # stabilised ports' [k..., c..., k given..., c given...]


@dataclass(frozen=True)
class SplineTerms:
    """A set of spline dampers as g = v * slope + offset + Relu(v @ select - knots) @ kink_slopes, all (1, nn) rows.

    `select` (nn, K) copies each damper's velocity to its interior knots, `kink_slopes` (K, nn) adds each knot's
    change of slope to its damper's force.
    """

    slope: np.ndarray
    offset: np.ndarray
    select: np.ndarray
    knots: np.ndarray
    kink_slopes: np.ndarray


def spline_terms(laws: list[SplineDamper]) -> SplineTerms:
    """The Relu form of the piecewise-linear force-velocity tables `laws` (one per nonlinear element)."""
    slope, offset, knots, owner, changes = [], [], [], [], []
    for j, law in enumerate(laws):
        v = np.asarray(law.velocity, dtype=float)
        f = np.asarray(law.force, dtype=float)
        slopes = np.diff(f) / np.diff(v)
        slope.append(slopes[0])
        offset.append(f[0] - slopes[0] * v[0])
        knots.extend(v[1:-1])
        owner.extend([j] * (len(v) - 2))
        changes.extend(np.diff(slopes))
    n, k = len(laws), len(knots)
    select = np.zeros((n, k))
    kink_slopes = np.zeros((k, n))
    select[owner, np.arange(k)] = 1.0
    kink_slopes[np.arange(k), owner] = changes
    return SplineTerms(np.array(slope), np.array(offset), select, np.array(knots), kink_slopes)


def _affine(graph: GraphBuilder, row: str, matrix: str, bias: str, name: str) -> str:
    """row (1, n) @ matrix.T + bias, with `matrix` stored (m, n)."""
    return graph.node("Gemm", [row, matrix, bias], name, transB=1)


def _spline(graph: GraphBuilder, v: str, terms: dict[str, str], name: str) -> str:
    """Forces of the spline dampers at velocities v (1, nn)."""
    linear = graph.node(
        "Add", [graph.node("Mul", [v, terms["slope"]], f"{name}_slope"), terms["offset"]], f"{name}_line"
    )
    if "select" not in terms:
        return linear
    spread = graph.node("MatMul", [v, terms["select"]], f"{name}_at_knots")
    past = graph.node("Relu", [graph.node("Sub", [spread, terms["knots"]], f"{name}_past_knots")], f"{name}_beyond")
    return graph.node("Add", [linear, graph.node("MatMul", [past, terms["kink_slopes"]], f"{name}_kinks")], name)


def discrete_step_graph(discrete: DiscreteVehicle, gains: GainCorrection | None = None) -> onnx.ModelProto:
    """The step graph of `discrete` (first-order hold): each evaluation after the first advances `discrete.dt`.
    With `gains`, the stabilised ports take their elements from the inputs `port_gains` at the interval start
    (`_gain_corrected`)."""
    if discrete.hold != "foh":
        raise VehicleBuildError(
            f"{discrete.vehicle.name}: hold {discrete.hold!r}; the FMU interpolates its inputs "
            "between samples (use 'foh')"
        )
    vehicle = discrete.vehicle
    nx, nu, ny = len(vehicle.states), len(vehicle.inputs), len(vehicle.outputs)
    reserved = (STATE_IN, FIRST_IN, INPUTS, INPUTS_START, OUTPUTS, STATE_OUT, FIRST_OUT, GAINS, GAINS_START)
    graph = GraphBuilder(reserved=reserved)
    spline = _spline_constants(graph, vehicle)
    if vehicle.is_linear:
        advanced = _linear_advance(graph, discrete)
    else:
        advanced = _advance(graph, discrete, spline, *_interval_inputs(graph, vehicle))
    graph_inputs = [_row(STATE_IN, nx), _row(FIRST_IN, 1), _row(INPUTS, nu), _row(INPUTS_START, nu)]
    if gains is not None:
        advanced = _gain_corrected(graph, gains, advanced)
        graph_inputs += [_row(GAINS, 4 * len(gains.ports)), _row(GAINS_START, 4 * len(gains.ports))]
    keep = graph.node("Mul", [FIRST_IN, STATE_IN], "kept_state")
    later = graph.node("Sub", [graph.constant("one", np.ones(1)), FIRST_IN], "later_sample")
    state = graph.node("Add", [graph.node("Mul", [later, advanced], "advanced_state"), keep], "state")
    at_sample = graph.node("Concat", [state, INPUTS], "state_and_inputs", axis=1)
    output_matrix = np.hstack([vehicle.C, vehicle.D])
    if not vehicle.is_linear:
        force = _damper_forces(graph, at_sample, spline, "output_force")
        at_sample = graph.node("Concat", [at_sample, force], "state_inputs_and_forces", axis=1)
        output_matrix = np.hstack([output_matrix, vehicle.Dyn])
    out, out_offset = graph.constant("output_matrix", output_matrix), graph.constant("output_offset", vehicle.e)
    y = _affine(graph, at_sample, out, out_offset, "outputs")
    graph.output(y, OUTPUTS)
    graph.output(state, STATE_OUT)
    graph.output(graph.node("Mul", [FIRST_IN, graph.constant("zero", np.zeros(1))], "not_first"), FIRST_OUT)
    onnx_graph = helper.make_graph(
        graph.nodes,
        vehicle.name,
        graph_inputs,
        [_row(OUTPUTS, ny), _row(STATE_OUT, nx), _row(FIRST_OUT, 1)],
        graph.initializers,
        doc_string=f"exact discrete step of {vehicle.description}, {discrete.dt:g} s",
    )
    model = helper.make_model(onnx_graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="nnfmu")
    model.ir_version = IR_VERSION
    return model


def _spline_constants(graph: GraphBuilder, vehicle: LinearVehicle) -> dict[str, str]:
    """Initializers of the spline dampers' stroke velocities and Relu form (none for a linear vehicle)."""
    if vehicle.is_linear:
        return {}
    terms = spline_terms(vehicle.feedback_laws)
    names = {
        "rate_matrix": graph.constant("damper_rate_matrix", np.hstack([vehicle.Cn, vehicle.Dn])),
        "zero_rate": graph.constant("zero_damper_rate", np.zeros(len(vehicle.feedback_laws))),
        "slope": graph.constant("spline_slope", terms.slope),
        "offset": graph.constant("spline_offset", terms.offset),
    }
    if terms.knots.size:
        names |= {
            "select": graph.constant("spline_select", terms.select),
            "knots": graph.constant("spline_knots", terms.knots),
            "kink_slopes": graph.constant("spline_kink_slopes", terms.kink_slopes),
        }
    return names


def _damper_forces(graph: GraphBuilder, state_and_inputs: str, spline: dict[str, str], name: str) -> str:
    """Forces g of the spline dampers from the row [x, u]: the splines at their stroke velocities Cn x + Dn u."""
    velocity = _affine(graph, state_and_inputs, spline["rate_matrix"], spline["zero_rate"], f"{name}_velocity")
    return _spline(graph, velocity, spline, name)


def _interval_inputs(graph: GraphBuilder, vehicle: LinearVehicle) -> tuple[str, str]:
    """The inputs at the interval's start and end as the advance sees them: `u_start` and `u`, except that a
    stabilised force port keeps its start value (its deviation from the reference is held), and less S x (x at the
    sample's start) for a vehicle with stabilised force ports."""
    if not np.any(vehicle.stabiliser):
        return INPUTS_START, INPUTS
    held = graph.constant("held_ports", vehicle.stabilised_inputs.astype(float))
    kept = graph.node("Mul", [INPUTS_START, held], "held_port_values")
    ramped = graph.node(
        "Mul", [INPUTS, graph.constant("ramped_ports", 1.0 - vehicle.stabilised_inputs)], "ramped_port_values"
    )
    end = graph.node("Add", [ramped, kept], "inputs_at_end")
    force = _affine(
        graph,
        STATE_IN,
        graph.constant("stabiliser", vehicle.stabiliser),
        graph.constant("zero_inputs", np.zeros(len(vehicle.inputs))),
        "stabiliser_force",
    )
    return (
        graph.node("Sub", [INPUTS_START, force], "held_inputs_start"),
        graph.node("Sub", [end, force], "held_inputs_end"),
    )


def _along(graph: GraphBuilder, start: str, end: str, fraction: float, name: str) -> str:
    """start + fraction (end - start): the inputs a fraction of the way through the interval."""
    if fraction == 0.0:
        return start
    if fraction == 1.0:
        return end
    from_start = graph.node(
        "Mul", [start, graph.constant(f"{name}_start_weight", np.array([1.0 - fraction]))], f"{name}_from_start"
    )
    from_end = graph.node("Mul", [end, graph.constant(f"{name}_end_weight", np.array([fraction]))], f"{name}_from_end")
    return graph.node("Add", [from_start, from_end], name)


def _linear_advance(graph: GraphBuilder, discrete: DiscreteVehicle) -> str:
    """The exact state of a linear vehicle one step of `discrete.dt` after x: Ad x + Bd0 (u_start - S x) + Bd1 (end -
    S x) + fd, with end = u_start at a stabilised port and u elsewhere (`_interval_inputs`), as one product of [x,
    u_start, u] whose matrix holds S and the held ports (the columns of u at held ports are zero, and the generated
    C leaves them out): per evaluation one product instead of S x, four element-wise nodes and a product a third
    larger."""
    vehicle = discrete.vehicle
    held = vehicle.stabilised_inputs
    on_start = discrete.Bd1 * held  # a held port's end value is its start value
    matrix = np.hstack(
        [
            discrete.Ad - (discrete.Bd0 + discrete.Bd1) @ vehicle.stabiliser,
            discrete.Bd0 + on_start,
            np.where(held, 0.0, discrete.Bd1),
        ]
    )
    state_input = graph.node("Concat", [STATE_IN, INPUTS_START, INPUTS], "start_state_and_inputs", axis=1)
    step = graph.constant("step_matrix", matrix)
    return _affine(graph, state_input, step, graph.constant("step_offset", discrete.fd), "advanced")


def _advance(graph: GraphBuilder, discrete: DiscreteVehicle, spline: dict[str, str], start: str, end: str) -> str:
    """The state of a vehicle with spline dampers one step of `discrete.dt` after x with inputs linear from `start`
    to `end`: `discrete.substeps` predictor-corrector sub-steps."""
    vehicle = discrete.vehicle
    predict = graph.constant("predict_matrix", np.hstack([discrete.Ad, discrete.Bd0, discrete.Bd1, discrete.Bnd]))
    predict_offset = graph.constant("predict_offset", discrete.fd)
    correct = graph.constant("correct_matrix", discrete.Bnr)
    no_correction = graph.constant("zero_correction", np.zeros(len(vehicle.states)))
    x = STATE_IN
    m = discrete.substeps
    for j in range(m):
        tag = f"sub{j + 1}"
        u0 = _along(graph, start, end, j / m, f"{tag}_inputs_start")
        u1 = _along(graph, start, end, (j + 1) / m, f"{tag}_inputs_end")
        at_start = graph.node("Concat", [x, u0], f"{tag}_state_and_inputs", axis=1)
        g0 = _damper_forces(graph, at_start, spline, f"{tag}_force")
        held = graph.node("Concat", [x, u0, u1, g0], f"{tag}_with_force", axis=1)
        predicted = _affine(graph, held, predict, predict_offset, f"{tag}_predicted")
        at_end = graph.node("Concat", [predicted, u1], f"{tag}_predicted_and_inputs", axis=1)
        g1 = _damper_forces(graph, at_end, spline, f"{tag}_end_force")
        change = graph.node("Sub", [g1, g0], f"{tag}_force_change")
        x = graph.node(
            "Add", [predicted, _affine(graph, change, correct, no_correction, f"{tag}_ramp")], f"{tag}_state"
        )
    return x


def _gain_corrected(graph: GraphBuilder, gains: GainCorrection, advanced: str) -> str:
    """`advanced` (the step on the fitted elements) corrected for the ports' elements given at the interval start,
    `port_gains_start` = [k..., c..., k given..., c given...] (4 ns): dk = k_given (Relu(k) - k0), dc likewise, then
    `GainCorrection.correct`. The end values `port_gains` reach the graph only times 0 (the FMU feeds every input
    tensor; the step holds the values given at its start)."""
    ns = len(gains.ports)
    size = 4 * ns
    parts = []
    for i, n in enumerate(("stiffness", "damping", "stiffness_given", "damping_given")):
        pick = np.zeros((size, ns))
        pick[i * ns + np.arange(ns), np.arange(ns)] = 1.0
        parts.append(graph.node("MatMul", [GAINS_START, graph.constant(f"pick_{n}", pick)], f"input_{n}"))
    k, c, k_given, c_given = parts
    end = graph.node("MatMul", [GAINS, graph.constant("ignore_end_gains", np.zeros((size, 1)))], "gains_end")
    nothing = graph.node("Mul", [end, graph.constant("zero_gain", np.zeros(1))], "nothing")

    def change(given: str, value: str, fitted: np.ndarray, name: str) -> str:
        passive = graph.node("Relu", [value], f"passive_{name}")
        moved = graph.node("Sub", [passive, graph.constant(f"fitted_{name}", fitted)], f"{name}_change_given")
        return graph.node("Add", [graph.node("Mul", [given, moved], f"{name}_change_used"), nothing], f"{name}_change")

    dk = change(k_given, k, gains.fitted[:, 0], "stiffness")
    dc = change(c_given, c, gains.fitted[:, 1], "damping")
    moved = graph.node("Sub", [advanced, STATE_IN], "moved")

    def rows(name: str, matrix: np.ndarray, row: str) -> str:
        return graph.node("MatMul", [row, graph.constant(name, np.ascontiguousarray(matrix.T))], f"{name}_of_{row}")

    def weighted(d_part: str, r_part: str, name: str) -> str:
        return graph.node(
            "Add", [graph.node("Mul", [dk, d_part], f"{name}_k"), graph.node("Mul", [dc, r_part], f"{name}_c")], name
        )

    pulled = weighted(rows("port_deflection", gains.deflection, moved), rows("port_rate", gains.rate, moved), "pulled")
    diag_d = graph.constant("own_deflection_ramp", np.diag(gains.deflection_ramp).copy())
    diag_r = graph.constant("own_rate_ramp", np.diag(gains.rate_ramp).copy())
    coupled = weighted(diag_d, diag_r, "own_coupling")
    one_less = graph.node("Sub", [graph.constant("diagonal_one", np.ones(1)), coupled], "diagonal_raw")
    floor = graph.constant("diagonal_floor", np.array([MIN_DIAGONAL]))
    diagonal = graph.node(
        "Add",
        [floor, graph.node("Relu", [graph.node("Sub", [one_less, floor], "over_floor")], "above_floor")],
        "diagonal",
    )
    first = graph.node("Div", [pulled, diagonal], "first_force")
    off_d = gains.deflection_ramp - np.diag(np.diag(gains.deflection_ramp))
    off_r = gains.rate_ramp - np.diag(np.diag(gains.rate_ramp))
    cross = weighted(rows("cross_deflection_ramp", off_d, first), rows("cross_rate_ramp", off_r, first), "cross")
    force = graph.node("Div", [graph.node("Add", [pulled, cross], "pulled_and_cross"), diagonal], "ramp_force")
    return graph.node("Add", [advanced, rows("port_ramp", gains.ramp, force)], "gain_corrected")


def _row(name: str, size: int) -> onnx.ValueInfoProto:
    return helper.make_tensor_value_info(name, TensorProto.DOUBLE, [1, size])
