"""ONNX nodes of nnfmu's torch networks for one sample, built from the trained weights (not by tracing torch).

The GRU is written out as its gate equations with Gemm, Slice, Add, Mul and Tanh (sigmoid(x) = (1 + tanh(x/2))/2)
instead of the ONNX GRU operator, because onnxruntime's CPU GRU kernel has no float64 version and nnfmu's graphs
are float64 throughout.
"""

from __future__ import annotations

import numpy as np
import torch

from nnfmu.export.errors import ExportError
from nnfmu.export.graph import GraphBuilder
from nnfmu.export.initializers import HIDDEN_LAYER, OUTPUT_LAYER, layer_initializers
from nnfmu.models.networks import MLP, GRUNet


def _weights(layer: torch.nn.Linear) -> tuple[np.ndarray, np.ndarray]:
    return layer.weight.detach().cpu().double().numpy(), layer.bias.detach().cpu().double().numpy()


def _linear(g: GraphBuilder, x: str, layer: torch.nn.Linear, name: str) -> str:
    """x [1, n_in] -> [1, n_out] = x W^T + b."""
    weight, bias = _weights(layer)
    weight_name, bias_name = layer_initializers(name)
    return g.node("Gemm", [x, g.constant(weight_name, weight), g.constant(bias_name, bias)], f"{name}_gemm", transB=1)


def _columns(g: GraphBuilder, x: str, start: int, end: int, name: str) -> str:
    """x[:, start:end] of a [1, n] tensor."""
    starts = g.constant(f"{name}_start", np.array([start], dtype=np.int64))
    ends = g.constant(f"{name}_end", np.array([end], dtype=np.int64))
    axes = g.constant(f"{name}_axis", np.array([1], dtype=np.int64))
    return g.node("Slice", [x, starts, ends, axes], name)


def _sigmoid(g: GraphBuilder, x: str, name: str) -> str:
    half = g.constant("half", np.array([0.5]))
    t = g.node("Tanh", [g.node("Mul", [x, half], f"{name}_half_input")], f"{name}_tanh")
    return g.node("Add", [g.node("Mul", [t, half], f"{name}_half_tanh"), half], name)


def mlp_nodes(g: GraphBuilder, network: MLP, x: str) -> str:
    """Scaled features [1, n_in] -> scaled output [1, n_out] of the tanh perceptron."""
    hidden = g.node("Tanh", [_linear(g, x, network.hidden, HIDDEN_LAYER)], "hidden_tanh")
    return _linear(g, hidden, network.out, OUTPUT_LAYER)


def gru_nodes(g: GraphBuilder, network: GRUNet, x: str, h: str) -> tuple[str, str]:
    """One GRU step: scaled features [1, n_in], hidden [1, H] -> (scaled output [1, n_out], next hidden [1, H]).

    torch's equations, gate order r, z, n: r = s(Wr x + Ur h), z = s(Wz x + Uz h), n = tanh(Wn x + r (Un h)),
    h' = (1 - z) n + z h, written as n + z (h - n). Biases ride along inside each Gemm.
    """
    gru = network.gru
    if gru.num_layers != 1 or gru.bidirectional or not gru.bias:
        raise ExportError("only a single-layer, unidirectional GRU with biases can be exported")
    size = gru.hidden_size
    w_ih = g.constant("gru_input_weight", gru.weight_ih_l0.detach().double().numpy())
    b_ih = g.constant("gru_input_bias", gru.bias_ih_l0.detach().double().numpy())
    w_hh = g.constant("gru_hidden_weight", gru.weight_hh_l0.detach().double().numpy())
    b_hh = g.constant("gru_hidden_bias", gru.bias_hh_l0.detach().double().numpy())
    from_input = g.node("Gemm", [x, w_ih, b_ih], "gru_input_gemm", transB=1)
    from_hidden = g.node("Gemm", [h, w_hh, b_hh], "gru_hidden_gemm", transB=1)
    input_rz = _columns(g, from_input, 0, 2 * size, "gru_input_rz")
    hidden_rz = _columns(g, from_hidden, 0, 2 * size, "gru_hidden_rz")
    gates = _sigmoid(g, g.node("Add", [input_rz, hidden_rz], "gru_rz_sum"), "gru_rz")
    reset = _columns(g, gates, 0, size, "gru_reset_gate")
    update = _columns(g, gates, size, 2 * size, "gru_update_gate")
    input_n = _columns(g, from_input, 2 * size, 3 * size, "gru_input_n")
    hidden_n = _columns(g, from_hidden, 2 * size, 3 * size, "gru_hidden_n")
    reset_hidden = g.node("Mul", [reset, hidden_n], "gru_reset_hidden")
    candidate = g.node("Tanh", [g.node("Add", [input_n, reset_hidden], "gru_candidate_sum")], "gru_candidate")
    keep = g.node("Mul", [update, g.node("Sub", [h, candidate], "gru_hidden_minus_candidate")], "gru_keep")
    h_next = g.node("Add", [candidate, keep], "gru_hidden_next")
    return _linear(g, h_next, network.out, OUTPUT_LAYER), h_next


def max_abs_weight(network: MLP | GRUNet) -> float:
    """Largest |parameter| of the network (a sanity figure for fixed-size C code and for training health)."""
    return max(float(p.detach().abs().max()) for p in network.parameters())
