"""Matrix products: Gemm (with transposes, alpha, beta and a broadcast bias) and numpy-style MatMul, with their
tangents by the product rule (terms of constant operands, such as weights, left out).

A Gemm sums each output's products in the order of the inner index, as the plain loop does, but keeps one accumulator
per output column and adds the columns side by side (each output's sum is one chain of dependent additions; side by
side the processor overlaps them), and with a mostly-zero constant B (a vehicle's output and stabiliser matrices)
writes out only its nonzero products, each output's as one expression 0 + p_1 + p_2 + ... in the order of the inner
index (its sum stays in a register); a denser constant B's all-zero rows (the input ports a vehicle holds over its
step) are left out of the loop. The sums are those of the plain loop bit for bit for finite operands (leaving out a
product 0 * a only changes a result where a is infinite or NaN).
"""

from __future__ import annotations

import math

import numpy as np

from nnfmu.fmu.native.codegen.emitters.base import Emitter, Node, Params, TangentParams, TensorType
from nnfmu.fmu.native.codegen.emitters.loops import broadcast_access, contiguous_strides
from nnfmu.fmu.native.codegen.tensors import c_literal

SPARSE_SHARE = 0.5  # a constant B with at most this share of nonzero entries has its products written out one by one
MAX_WRITTEN_OUT = 4096  # at most this many products written out (more: the loop over every entry)
MAX_SIDE_BY_SIDE = 1024  # at most this many output columns summed side by side (their accumulators on the stack)
MAX_REORDERED = (
    16384  # a constant B' stored by columns is copied by rows (read in the order of the sums) up to this size
)


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
        return self._product(node, params.x[0], params.x[1], bias, params.y[0], "=", _constant_b(node))

    def _product(
        self,
        node: Node,
        x_a: str | None,
        x_b: str | None,
        bias: str | None,
        y: str,
        assign: str,
        b_value: np.ndarray | None = None,
    ) -> list[str]:
        """`y assign alpha * A' B' + beta * C`, with the product left out when an operand is None and the bias term
        when `bias` is None (or beta is 0); `assign` is "=" or "+="; `b_value`: B's value when `x_b` is a constant
        known now (its zero entries are then left out where they are most)."""
        (m, k, a_row, a_col), (_, n, b_row, b_col) = self._dims(node)
        dtype = node.input(0).dtype
        alpha, beta = float(node.attr("alpha", 1.0)), float(node.attr("beta", 1.0))
        ctype = node.input(0).ctype
        product = x_a is not None and x_b is not None
        side_by_side = product and 1 < n <= MAX_SIDE_BY_SIDE
        acc = "acc[c]" if side_by_side else "acc"
        terms = []
        if product:
            terms.append(acc if alpha == 1.0 else f"{c_literal(alpha, dtype)} * {acc}")
        if bias is not None and beta != 0.0:
            access = broadcast_access(node.input(2).shape, (m, n))
            term = f"{bias}[{_index(access.strides[0], 'r', access.strides[1], 'c')}]"
            terms.append(term if beta == 1.0 else f"{c_literal(beta, dtype)} * {term}")
        store = [
            f"    for (int c = 0; c < {n}; ++c) {{",
            f"        {y}[{n} * r + c] {assign} {' + '.join(terms) or c_literal(0.0, dtype)};",
            "    }",
        ]
        if side_by_side:
            lines = [f"for (int r = 0; r < {m}; ++r) {{", f"    {ctype} acc[{n}];"]
            nonzero = _written_out(b_value, b_row, b_col, k, n)
            if nonzero is not None:
                # each output's sum as one expression, 0 + p_1 + p_2 + ... (C adds left to right: the order of the
                # loop), kept in a register instead of stored and loaded again after every product
                row = _index(a_row, "r", 0, "")
                products: list[list[str]] = [[] for _ in range(n)]
                for j, c in nonzero:
                    products[c].append(f"{x_a}[{row} + {a_col * j}] * {x_b}[{b_row * j + b_col * c}]")
                lines += [
                    f"    acc[{c}] = {' + '.join([c_literal(0.0, dtype), *terms])};" for c, terms in enumerate(products)
                ]
                if not nonzero:
                    lines += [f"    (void){x_a};", f"    (void){x_b};"]
            else:
                lines += [
                    f"    for (int c = 0; c < {n}; ++c) {{",
                    f"        acc[c] = {c_literal(0.0, dtype)};",
                    "    }",
                ]
                b_read = f"{x_b}[{_index(b_row, 'j', b_col, 'c')}]"
                if b_value is not None and b_col != 1 and k * n <= MAX_REORDERED:
                    lines = [*_by_rows(b_value, k, n, ctype, dtype), f"(void){x_b};", *lines]
                    b_read = f"b_by_rows[{n} * j + c]"
                for start, stop in _live_rows(b_value, b_row, b_col, k, n):
                    lines += [
                        f"    for (int j = {start}; j < {stop}; ++j) {{",
                        f"        const {ctype} a_j = {x_a}[{_index(a_row, 'r', a_col, 'j')}];",
                        f"        for (int c = 0; c < {n}; ++c) {{",
                        f"            acc[c] += a_j * {b_read};",
                        "        }",
                        "    }",
                    ]
            return [*lines, *store, "}"]
        lines = [f"for (int r = 0; r < {m}; ++r) {{", f"    for (int c = 0; c < {n}; ++c) {{"]
        if product:
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
        lines = self._product(node, d_a, x_b, d_c, dy, "=", _constant_b(node)) if d_a is not None else []
        if d_b is not None:
            lines += self._product(node, x_a, d_b, None if lines else d_c, dy, "+=" if lines else "=")
        return lines


def _constant_b(node: Node) -> np.ndarray | None:
    """Gemm's B when it is a constant known now, else None."""
    tensor = node.input(1)
    return tensor.value if tensor.is_constant else None


def _by_rows(b_value: np.ndarray, k: int, n: int, ctype: str, dtype: np.dtype) -> list[str]:
    """A static copy of a constant B' (k, n), given as B (n, k), stored row by row: the loop over the output columns
    then reads it in order (which the compiler can turn into vector instructions)."""
    values = [c_literal(v, dtype) for v in np.ravel(np.asarray(b_value).reshape(n, k).T)]
    rows = [", ".join(values[i : i + 8]) for i in range(0, len(values), 8)]
    return [f"static const {ctype} b_by_rows[{k * n}] = {{", *(f"    {row}," for row in rows), "};"]


def _b_prime(b_value: np.ndarray, b_row: int, b_col: int, k: int, n: int) -> np.ndarray:
    """A constant B as the product reads it, B'[j, c] (k, n): B itself, or B stored (n, k) transposed."""
    flat = np.ravel(b_value)
    return flat.reshape(k, n) if (b_row, b_col) == (n, 1) else flat.reshape(n, k).T


def _live_rows(b_value: np.ndarray | None, b_row: int, b_col: int, k: int, n: int) -> list[tuple[int, int]]:
    """The runs [start, stop) of inner indices j whose row B'[j, :] has a nonzero entry (all of 0..k when B is not a
    constant known now): a constant's all-zero rows (a vehicle's held input ports) are left out of the loop."""
    if b_value is None:
        return [(0, k)]
    live = np.flatnonzero(np.any(_b_prime(b_value, b_row, b_col, k, n) != 0.0, axis=1))
    if live.size == 0:  # (an all-zero B is written out as sparse before it gets here)
        return [(0, k)]
    breaks = np.flatnonzero(np.diff(live) > 1)
    starts = [int(live[0]), *(int(live[i + 1]) for i in breaks)]
    stops = [*(int(live[i]) + 1 for i in breaks), int(live[-1]) + 1]
    return list(zip(starts, stops))


def _written_out(b_value: np.ndarray | None, b_row: int, b_col: int, k: int, n: int) -> list[tuple[int, int]] | None:
    """The (j, c) of B's nonzero entries B'[j, c], j first, when the products are to be written out one by one (a
    mostly-zero constant B, not too many of them); None to loop over every entry."""
    if b_value is None:
        return None
    rows, cols = np.nonzero(_b_prime(b_value, b_row, b_col, k, n))  # j first, then c
    if rows.size > SPARSE_SHARE * k * n or rows.size > MAX_WRITTEN_OUT:
        return None
    return list(zip(rows.tolist(), cols.tolist()))


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
