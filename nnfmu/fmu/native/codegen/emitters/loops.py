"""Loop nests over a static output shape with per-operand strides: broadcasting, slicing and transposes."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Access:
    """How one operand is read along the output's loop nest: flat element `offset + sum(i_k * strides[k])`."""

    offset: int
    strides: tuple[int, ...]


def contiguous_strides(shape: tuple[int, ...]) -> tuple[int, ...]:
    """Row-major element strides of `shape`."""
    strides = []
    step = 1
    for dim in reversed(shape):
        strides.append(step)
        step *= dim
    return tuple(reversed(strides))


def broadcast_access(shape: tuple[int, ...], out_shape: tuple[int, ...]) -> Access:
    """Reading a tensor of `shape` broadcast (numpy rules) to `out_shape`."""
    padded = (1,) * (len(out_shape) - len(shape)) + tuple(shape)
    strides = contiguous_strides(padded)
    return Access(0, tuple(0 if dim == 1 else s for dim, s in zip(padded, strides)))


def loop_nest(
    out_shape: tuple[int, ...], accesses: list[Access], statement: Callable[[list[str], str], str]
) -> list[str]:
    """C lines looping over `out_shape`; `statement(operand index expressions, output index)` is the loop body."""
    size = math.prod(out_shape)
    plain = Access(0, contiguous_strides(out_shape))
    if all(_reads_flat(a, plain, out_shape) for a in accesses):
        if size == 1:
            return [statement(["0"] * len(accesses), "0")]
        return [f"for (int i = 0; i < {size}; ++i) {{", f"    {statement(['i'] * len(accesses), 'i')}", "}"]
    loop_dims = [k for k, dim in enumerate(out_shape) if dim > 1]
    lines: list[str] = []
    indent = ""
    if loop_dims:
        lines.append("int k = 0;")
    for k in loop_dims:
        lines.append(f"{indent}for (int i{k} = 0; i{k} < {out_shape[k]}; ++i{k}) {{")
        indent += "    "
    operands = [_index(a, loop_dims) for a in accesses]
    lines.append(indent + statement(operands, "k++" if loop_dims else "0"))
    for _ in loop_dims:
        indent = indent[:-4]
        lines.append(f"{indent}}}")
    return lines


def _reads_flat(access: Access, plain: Access, out_shape: tuple[int, ...]) -> bool:
    """True when the operand is read element by element in output order."""
    if access.offset != 0:
        return False
    return all(a == p or dim == 1 for a, p, dim in zip(access.strides, plain.strides, out_shape))


def _index(access: Access, loop_dims: list[int]) -> str:
    """The C index expression of one operand."""
    terms = [str(access.offset)] if access.offset else []
    for k in loop_dims:
        stride = access.strides[k]
        if stride == 1:
            terms.append(f"i{k}")
        elif stride != 0:
            terms.append(f"{stride} * i{k}")
    return " + ".join(terms) or "0"
