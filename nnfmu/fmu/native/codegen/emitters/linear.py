"""Matrix products: Gemm (with transposes, alpha, beta and a broadcast bias) and numpy-style MatMul, with their
tangents by the product rule (terms of constant operands, such as weights, left out)."""

from __future__ import annotations

import math

import numpy as np

from nnfmu.fmu.native.codegen.emitters.base import Emitter, Node, Params, TangentParams, TensorType
from nnfmu.fmu.native.codegen.emitters.loops import broadcast_access, contiguous_strides
from nnfmu.fmu.native.codegen.tensors import c_literal


def _matrix(node: Node, index: int, transposed: bool) -> tuple[int, int, int, int]:
    """Rows, columns and the row/column element strides of a 2-D operand read as (optionally) transposed."""
    shape = node.input(index).shape
    if len(shape) != 2:
        raise node.fail(f"input {index} must be 2-D, got shape {shape}")
    rows, cols = shape
    return (cols, rows, 1, cols) if transposed else (rows, cols, cols, 1)


def _index(stride_a: int, var_a: str, stride_b: int, var_b: str) -> str:
    """`stride_a * var_a + stride_b * var_b` without zero terms or unit factors."""
    pairs = ((stride_a, var_a), (stride_b, var_b))
    terms = [var if stride == 1 else f"{stride} * {var}" for stride, var in pairs if stride]
    return " + ".join(terms) or "0"


class Gemm(Emitter):
    """Y = alpha * A' B' + beta * C with A' = A or A^T, B' = B or B^T, C broadcast to (M, N)."""

    def _dims(self, node: Node) -> tuple[tuple[int, int, int, int], tuple[int, int, int, int]]:
        a = _matrix(node, 0, bool(node.attr("transA", 0)))
        b = _matrix(node, 1, bool(node.attr("transB", 0)))
        if a[1] != b[0]:
            raise node.fail(f"inner dimensions differ: {node.input(0).shape} x {node.input(1).shape}")
        return a, b

    def skipped_inputs(self, node: Node) -> frozenset[int]:
        return frozenset({2}) if float(node.attr("beta", 1.0)) == 0.0 else frozenset()

    def infer(self, node: Node) -> list[TensorType]:
        dtype = node.runtime_dtype(0)
        if node.runtime_dtype(1) != dtype or (node.optional(2) is not None and node.runtime_dtype(2) != dtype):
            raise node.fail("operands have different dtypes")
        a, b = self._dims(node)
        bias = node.optional(2)
        if bias is not None:
            try:
                np.broadcast_shapes(bias.shape, (a[0], b[1]))
            except ValueError as err:
                raise node.fail(f"bias shape {bias.shape} does not broadcast to {(a[0], b[1])}") from err
        return [(dtype, (a[0], b[1]))]

    def body(self, node: Node, params: Params) -> list[str]:
        bias = params.x[2] if len(params.x) > 2 and node.optional(2) is not None else None
        return self._product(node, params.x[0], params.x[1], bias, params.y[0], "=")

    def _product(
        self, node: Node, x_a: str | None, x_b: str | None, bias: str | None, y: str, assign: str
    ) -> list[str]:
        """`y assign alpha * A' B' + beta * C`, with the product left out when an operand is None and the bias term
        when `bias` is None (or beta is 0); `assign` is "=" or "+="."""
        (m, k, a_row, a_col), (_, n, b_row, b_col) = self._dims(node)
        dtype = node.input(0).dtype
        alpha, beta = float(node.attr("alpha", 1.0)), float(node.attr("beta", 1.0))
        ctype = node.input(0).ctype
        terms = []
        if x_a is not None and x_b is not None:
            terms.append("acc" if alpha == 1.0 else f"{c_literal(alpha, dtype)} * acc")
        if bias is not None and beta != 0.0:
            access = broadcast_access(node.input(2).shape, (m, n))
            term = f"{bias}[{_index(access.strides[0], 'r', access.strides[1], 'c')}]"
            terms.append(term if beta == 1.0 else f"{c_literal(beta, dtype)} * {term}")
        lines = [f"for (int r = 0; r < {m}; ++r) {{", f"    for (int c = 0; c < {n}; ++c) {{"]
        if x_a is not None and x_b is not None:
            a_index, b_index = _index(a_row, "r", a_col, "j"), _index(b_row, "j", b_col, "c")
            lines += [
                f"        {ctype} acc = {c_literal(0.0, dtype)};",
                f"        for (int j = 0; j < {k}; ++j) {{",
                f"            acc += {x_a}[{a_index}] * {x_b}[{b_index}];",
                "        }",
            ]
        lines += [f"        {y}[{n} * r + c] {assign} {' + '.join(terms) or c_literal(0.0, dtype)};", "    }", "}"]
        return lines

    def tangent(self, node: Node, params: TangentParams) -> list[str] | None:
        """dY = alpha (dA' B' + A' dB') + beta dC."""
        x_a, x_b = params.x[0], params.x[1]
        d_a, d_b = params.dx[0], params.dx[1]
        d_c = params.dx[2] if len(params.dx) > 2 and node.optional(2) is not None else None
        dy = params.dy[0]
        if d_a is None and d_b is None:
            return self._product(node, None, None, d_c, dy, "=")
        lines = self._product(node, d_a, x_b, d_c, dy, "=") if d_a is not None else []
        if d_b is not None:
            lines += self._product(node, x_a, d_b, None if lines else d_c, dy, "+=" if lines else "=")
        return lines


class MatMul(Emitter):
    """numpy.matmul: 1-D operands promoted and squeezed again, batch dimensions broadcast."""

    def _shapes(self, node: Node) -> tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...], tuple[int, ...]]:
        """Promoted A and B shapes, the broadcast batch shape and the final output shape."""
        a, b = node.input(0).shape, node.input(1).shape
        if not a or not b:
            raise node.fail("MatMul operands must have at least one dimension")
        a2 = (1, *a) if len(a) == 1 else a
        b2 = (*b, 1) if len(b) == 1 else b
        if a2[-1] != b2[-2]:
            raise node.fail(f"inner dimensions differ: {a} x {b}")
        try:
            batch = tuple(np.broadcast_shapes(a2[:-2], b2[:-2]))
        except ValueError as err:
            raise node.fail(f"batch dimensions of {a} and {b} do not broadcast") from err
        out = [*batch]
        if len(a) > 1:
            out.append(a2[-2])
        if len(b) > 1:
            out.append(b2[-1])
        return a2, b2, batch, tuple(out)

    def infer(self, node: Node) -> list[TensorType]:
        dtype = node.runtime_dtype(0)
        if node.runtime_dtype(1) != dtype:
            raise node.fail("operands have different dtypes")
        return [(dtype, self._shapes(node)[3])]

    def body(self, node: Node, params: Params) -> list[str]:
        return self._product(node, params.x[0], params.x[1], params.y[0], "=")

    def tangent(self, node: Node, params: TangentParams) -> list[str] | None:
        """dY = dA B + A dB."""
        (x_a, x_b), (d_a, d_b), dy = params.x, params.dx, params.dy[0]
        lines = self._product(node, d_a, x_b, dy, "=") if d_a is not None else []
        if d_b is not None:  # in a block of its own: each product may declare its batch offset tables
            second = self._product(node, x_a, d_b, dy, "+=" if lines else "=")
            lines += ["{", *("    " + line for line in second), "}"] if lines else second
        return lines

    def _product(self, node: Node, x_a: str, x_b: str, y: str, assign: str) -> list[str]:
        """`y assign A B` (assign "=" or "+=")."""
        a2, b2, batch, _ = self._shapes(node)
        m, k, n = a2[-2], a2[-1], b2[-1]
        dtype = node.input(0).dtype
        offsets_a = self._batch_offsets(a2, batch, m * k)
        offsets_b = self._batch_offsets(b2, batch, k * n)
        lines: list[str] = []
        count = math.prod(batch)
        a_base, b_base, y_base = "", "", ""
        if count > 1:
            lines.append(f"static const int a_off[{count}] = {{{', '.join(map(str, offsets_a))}}};")
            lines.append(f"static const int b_off[{count}] = {{{', '.join(map(str, offsets_b))}}};")
            lines.append(f"for (int s = 0; s < {count}; ++s) {{")
            a_base, b_base, y_base = "a_off[s] + ", "b_off[s] + ", f"{m * n} * s + "
        inner = [
            f"for (int r = 0; r < {m}; ++r) {{",
            f"    for (int c = 0; c < {n}; ++c) {{",
            f"        {node.input(0).ctype} acc = {c_literal(0.0, dtype)};",
            f"        for (int j = 0; j < {k}; ++j) {{",
            f"            acc += {x_a}[{a_base}{k} * r + j] * {x_b}[{b_base}{n} * j + c];",
            "        }",
            f"        {y}[{y_base}{n} * r + c] {assign} acc;",
            "    }",
            "}",
        ]
        if count > 1:
            return [*lines, *("    " + line for line in inner), "}"]
        return inner

    @staticmethod
    def _batch_offsets(shape: tuple[int, ...], batch: tuple[int, ...], matrix: int) -> list[int]:
        """Element offset of each (broadcast) batch matrix of an operand, in output batch order."""
        access = broadcast_access(shape[:-2], batch)
        strides = contiguous_strides(batch)
        offsets = []
        for flat in range(math.prod(batch)):
            index = [(flat // s) % d for s, d in zip(strides, batch)]
            offsets.append(sum(i * st for i, st in zip(index, access.strides)) * matrix)
        return offsets


EMITTERS: dict[str, Emitter] = {"Gemm": Gemm(), "MatMul": MatMul()}
