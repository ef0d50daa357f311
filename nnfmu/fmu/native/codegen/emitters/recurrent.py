"""ONNX GRU, forward direction, default activations (sigmoid gates, tanh candidate), either reset variant."""

from __future__ import annotations

import numpy as np

from nnfmu.fmu.native.codegen.emitters.base import Emitter, Node, Params, TensorType
from nnfmu.fmu.native.codegen.tensors import c_literal, math_fn


class Gru(Emitter):
    """GRU with gate order z, r, h; X [seq, batch, input], W [1, 3H, input], R [1, 3H, H], B [1, 6H]."""

    static_inputs = frozenset({4})

    def _dims(self, node: Node) -> tuple[int, int, int, int]:
        """Sequence length, batch, input size and hidden size, after checking every supported attribute."""
        if node.attr("direction", "forward") != "forward":
            raise node.fail(f"direction {node.attr('direction')!r} is not supported (only 'forward')")
        if node.attr("layout", 0) != 0:
            raise node.fail("layout 1 (batch first) is not supported")
        if node.attr("clip") is not None:
            raise node.fail("the clip attribute is not supported")
        activations = node.attr("activations")
        if activations is not None and [a.lower() for a in activations] != ["sigmoid", "tanh"]:
            raise node.fail(f"activations {activations} are not supported (only the default Sigmoid, Tanh)")
        x, r = node.input(0).shape, node.input(2).shape
        if len(x) != 3:
            raise node.fail(f"X must be 3-D [seq, batch, input], got {x}")
        seq, batch, width = x
        hidden = node.attr("hidden_size", r[-1] if len(r) == 3 else 0)
        expected = {1: (1, 3 * hidden, width), 2: (1, 3 * hidden, hidden), 3: (1, 6 * hidden), 5: (1, batch, hidden)}
        for index, shape in expected.items():
            tensor = node.optional(index)
            if tensor is not None and tensor.shape != shape:
                raise node.fail(f"input {index} has shape {tensor.shape}, expected {shape}")
        lengths = node.static(4)
        if lengths is not None and np.any(np.ravel(lengths) != seq):
            raise node.fail(f"sequence_lens {np.ravel(lengths).tolist()} differ from the sequence length {seq}")
        return seq, batch, width, hidden

    def infer(self, node: Node) -> list[TensorType]:
        dtype = node.runtime_dtype(0)
        for index in (1, 2, 3, 5):
            if node.optional(index) is not None and node.runtime_dtype(index) != dtype:
                raise node.fail(f"input {index} has dtype {node.input(index).dtype}, expected {dtype}")
        seq, batch, _, hidden = self._dims(node)
        return [(dtype, (seq, 1, batch, hidden)), (dtype, (1, batch, hidden))]

    def body(self, node: Node, params: Params) -> list[str]:
        seq, batch, width, hidden = self._dims(node)
        dtype = node.input(0).dtype
        ctype = node.input(0).ctype
        x, w, r, b, h0 = (params.x[i] for i in (0, 1, 2, 3, 5))
        exp, tanh = math_fn("exp", dtype), math_fn("tanh", dtype)
        zero, one = c_literal(0.0, dtype), c_literal(1.0, dtype)
        hh = hidden

        def bias(gate: int, offset: int) -> str:
            return f"{b}[{offset + gate * hh} + u]" if b else zero

        start = f"{h0}[i]" if h0 else zero
        if node.attr("linear_before_reset", 0):
            candidate = [
                f"            {ctype} hx = {bias(2, 0)};",
                f"            {ctype} hr = {bias(2, 3 * hh)};",
                f"            for (int i = 0; i < {width}; ++i) {{",
                f"                hx += {w}[{2 * hh * width} + {width} * u + i] * xt[i];",
                "            }",
                f"            for (int j = 0; j < {hh}; ++j) {{",
                f"                hr += {r}[{2 * hh * hh} + {hh} * u + j] * hp[j];",
                "            }",
                f"            cand[u] = {tanh}(hx + rg[u] * hr);",
            ]
        else:
            candidate = [
                f"            {ctype} acc = {bias(2, 0)} + {bias(2, 3 * hh)};",
                f"            for (int i = 0; i < {width}; ++i) {{",
                f"                acc += {w}[{2 * hh * width} + {width} * u + i] * xt[i];",
                "            }",
                f"            for (int j = 0; j < {hh}; ++j) {{",
                f"                acc += {r}[{2 * hh * hh} + {hh} * u + j] * (rg[j] * hp[j]);",
                "            }",
                f"            cand[u] = {tanh}(acc);",
            ]
        lines = [
            f"{ctype} h[{batch * hh}];",
            f"for (int i = 0; i < {batch * hh}; ++i) h[i] = {start};",
            f"for (int t = 0; t < {seq}; ++t) {{",
            f"    for (int n = 0; n < {batch}; ++n) {{",
            f"        const {ctype} *xt = {x} + {width} * ({batch} * t + n);",
            f"        {ctype} *hp = h + {hh} * n;",
            f"        {ctype} zg[{hh}], rg[{hh}], cand[{hh}];",
            f"        for (int u = 0; u < {hh}; ++u) {{",
            f"            {ctype} az = {bias(0, 0)} + {bias(0, 3 * hh)};",
            f"            {ctype} ar = {bias(1, 0)} + {bias(1, 3 * hh)};",
            f"            for (int i = 0; i < {width}; ++i) {{",
            f"                az += {w}[{width} * u + i] * xt[i];",
            f"                ar += {w}[{hh * width} + {width} * u + i] * xt[i];",
            "            }",
            f"            for (int j = 0; j < {hh}; ++j) {{",
            f"                az += {r}[{hh} * u + j] * hp[j];",
            f"                ar += {r}[{hh * hh} + {hh} * u + j] * hp[j];",
            "            }",
            f"            zg[u] = {one} / ({one} + {exp}(-az));",
            f"            rg[u] = {one} / ({one} + {exp}(-ar));",
            "        }",
            f"        for (int u = 0; u < {hh}; ++u) {{",
            *candidate,
            "        }",
            f"        for (int u = 0; u < {hh}; ++u) {{",
            f"            hp[u] = ({one} - zg[u]) * cand[u] + zg[u] * hp[u];",
        ]
        if params.y[0]:
            lines.append(f"            {params.y[0]}[{hh} * ({batch} * t + n) + u] = hp[u];")
        lines += ["        }", "    }", "}"]
        if params.y[1]:
            lines.append(f"for (int i = 0; i < {batch * hh}; ++i) {params.y[1]}[i] = h[i];")
        return lines


EMITTERS: dict[str, Emitter] = {"GRU": Gru()}
