"""Build the ONNX step function of a trained model: physical inputs and state at sample k -> output and next state.

Everything between the ports is in the graph: feature computation and delay lines (the spec's own nodes), min-max
scaling, the network, unscaling. State vector = the spec's slots (delay lines, filters) then the GRU hidden vector.
"""

from __future__ import annotations

import numpy as np
import onnx

from nnfmu.export.errors import ExportError
from nnfmu.export.graph import GraphBuilder
from nnfmu.export.initializers import FEATURE_GAIN, FEATURE_MIN, TARGET_GAIN, TARGET_MIN
from nnfmu.export.networks import gru_nodes, mlp_nodes
from nnfmu.models.features import StateSlot
from nnfmu.models.networks import MLP, GRUNet
from nnfmu.models.trained import TrainedModel

STATE = "state"
STATE_NEXT = "state_next"


def network_sizes(model: TrainedModel) -> tuple[str, list[int]]:
    """("mlp" | "gru", [n_in, hidden, n_out]) of the model's network."""
    net = model.network
    if isinstance(net, MLP):
        return "mlp", [net.hidden.in_features, net.hidden.out_features, net.out.out_features]
    if isinstance(net, GRUNet):
        return "gru", [net.gru.input_size, net.gru.hidden_size, net.out.out_features]
    raise ExportError(f"cannot export network of type {type(net).__name__}; expected MLP or GRUNet")


def state_layout(model: TrainedModel) -> list[StateSlot]:
    """The whole state vector: the feature spec's slots, then the GRU hidden vector (0 at rest)."""
    slots = model.spec.state_layout()
    kind, sizes = network_sizes(model)
    if kind == "gru":
        slots += [
            StateSlot(name=f"gru_hidden[{i}]", channel="", description="GRU hidden state") for i in range(sizes[1])
        ]
    return slots


def _check_model(model: TrainedModel) -> None:
    spec = model.spec
    _, (n_in, _, n_out) = network_sizes(model)
    if n_in != spec.n_features:
        raise ExportError(f"network takes {n_in} inputs but the feature spec has {spec.n_features} features")
    if n_out != 1:
        raise ExportError(f"network has {n_out} outputs; the step graph carries one output channel ({spec.output!r})")
    for label, scaler, size in (("feature", model.feature_scaler, spec.n_features), ("target", model.target_scaler, 1)):
        if np.size(scaler.lo) != size or np.size(scaler.hi) != size:
            raise ExportError(f"{label} scaler has {np.size(scaler.lo)} columns, expected {size}")
    if not (model.sample_period > 0 and np.isfinite(model.sample_period)):
        raise ExportError(f"sample period must be finite and > 0, got {model.sample_period!r}")
    if state_layout(model):
        for name in (*spec.channels, spec.output):
            if name in (STATE, STATE_NEXT):
                raise ExportError(f"channel {name!r} clashes with the step graph's state tensor of the same name")


def build_step_graph(model: TrainedModel, graph_name: str, doc: str) -> onnx.ModelProto:
    """The step graph of `model` (float64, opset graph.OPSET), without the component metadata."""
    _check_model(model)
    spec = model.spec
    layout = state_layout(model)
    n_spec, n_state = spec.state_size, len(layout)
    g = GraphBuilder(reserved=[*spec.channels, spec.output, STATE, STATE_NEXT])

    def state_part(start: int, end: int, name: str) -> str:
        if start == 0 and end == n_state:
            return STATE
        starts = g.constant(f"{name}_start", np.array([start], dtype=np.int64))
        ends = g.constant(f"{name}_end", np.array([end], dtype=np.int64))
        return g.node("Slice", [STATE, starts, ends], name)

    feature_state = state_part(0, n_spec, "feature_state") if n_spec else None
    features, feature_next = spec.emit(g, {c: c for c in spec.channels}, feature_state, model.sample_period)

    scaler = model.feature_scaler
    one = g.constant("one", np.array([1.0]))
    shifted = g.node("Sub", [features, g.constant(FEATURE_MIN, np.ravel(scaler.lo))], "features_minus_min")
    stretched = g.node("Mul", [shifted, g.constant(FEATURE_GAIN, np.ravel(scaler.gain))], "features_times_gain")
    scaled = g.node("Sub", [stretched, one], "scale_inputs")
    row = g.node("Reshape", [scaled, g.constant("row_shape", np.array([1, -1], dtype=np.int64))], "scaled_row")

    next_parts = [feature_next] if feature_next is not None else []
    if isinstance(model.network, GRUNet):
        hidden = state_part(n_spec, n_state, "gru_hidden")
        row_shape = g.constant("hidden_row_shape", np.array([1, -1], dtype=np.int64))
        hidden_row = g.node("Reshape", [hidden, row_shape], "gru_hidden_row")
        out, hidden_next = gru_nodes(g, model.network, row, hidden_row)
        flat = g.constant("flat_shape", np.array([-1], dtype=np.int64))
        next_parts.append(g.node("Reshape", [hidden_next, flat], "gru_hidden_next_flat"))
    else:
        out = mlp_nodes(g, model.network, row)

    target = model.target_scaler
    scaled_out = g.node("Reshape", [out, g.constant("output_shape", np.array([1], dtype=np.int64))], "scaled_output")
    shifted_out = g.node("Add", [scaled_out, one], "output_plus_one")
    unscaled = g.node("Div", [shifted_out, g.constant(TARGET_GAIN, np.ravel(target.gain))], "output_over_gain")
    y = g.node("Add", [unscaled, g.constant(TARGET_MIN, np.ravel(target.lo))], "unscale_output")
    g.output(y, spec.output)

    inputs = [(c, 1) for c in spec.channels]
    outputs = [(spec.output, 1)]
    if n_state:
        inputs.append((STATE, n_state))
        outputs.append((STATE_NEXT, n_state))
        joined = g.node("Concat", next_parts, "state_next_concat", axis=0) if len(next_parts) > 1 else next_parts[0]
        g.output(joined, STATE_NEXT)
    return g.model(graph_name, doc, inputs, outputs)
