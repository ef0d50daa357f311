"""Data movement: reshapes (copies), Transpose, Concat, Slice and Gather on constant indices; all linear, so each
one's tangent is itself applied to the tangents."""

from __future__ import annotations

import math

import numpy as np

from nnfmu.fmu.native.codegen.emitters.base import Linear, Node, Params, TensorType
from nnfmu.fmu.native.codegen.emitters.loops import Access, contiguous_strides, loop_nest


class Copy(Linear):
    """Operators that only change the shape (Identity, Reshape, Flatten, Squeeze, Unsqueeze): y = x elementwise."""

    def infer(self, node: Node) -> list[TensorType]:
        shape = self.shape(node)
        if math.prod(shape) != node.input(0).size:
            raise node.fail(f"cannot reshape {node.input(0).shape} to {shape}")
        return [(node.runtime_dtype(0), shape)]

    def shape(self, node: Node) -> tuple[int, ...]:
        """The output shape."""
        return node.input(0).shape

    def body(self, node: Node, params: Params) -> list[str]:
        return [f"for (int i = 0; i < {node.input(0).size}; ++i) {{", f"    {params.y[0]}[i] = {params.x[0]}[i];", "}"]


class Reshape(Copy):
    """Reshape to a constant target shape (0 copies a dimension unless allowzero, -1 is inferred)."""

    static_inputs = frozenset({1})

    def shape(self, node: Node) -> tuple[int, ...]:
        requested = node.static(1) if node.opset >= 5 else node.attr("shape")
        if requested is None:
            raise node.fail("the target shape is missing")
        requested = [int(d) for d in np.ravel(requested)]
        source = node.input(0).shape
        allow_zero = bool(node.attr("allowzero", 0))
        dims = [source[i] if d == 0 and not allow_zero and i < len(source) else d for i, d in enumerate(requested)]
        if dims.count(-1) > 1:
            raise node.fail(f"shape {requested} has more than one -1")
        if -1 in dims:
            known = math.prod(d for d in dims if d != -1)
            if known == 0 or node.input(0).size % known:
                raise node.fail(f"cannot reshape {source} to {requested}")
            dims[dims.index(-1)] = node.input(0).size // known
        return tuple(dims)


class Flatten(Copy):
    """Flatten to 2-D around `axis`."""

    def shape(self, node: Node) -> tuple[int, ...]:
        source = node.input(0).shape
        axis = node.attr("axis", 1)
        axis = axis + len(source) if axis < 0 else axis
        if not 0 <= axis <= len(source):
            raise node.fail(f"axis {node.attr('axis')} out of range for rank {len(source)}")
        return (math.prod(source[:axis]), math.prod(source[axis:]))


def _axes(node: Node) -> list[int] | None:
    """Axes from the attribute (opset < 13) or the optional constant input 1."""
    if node.opset < 13:
        axes = node.attr("axes")
        return None if axes is None else list(axes)
    value = node.static(1)
    return None if value is None else [int(a) for a in np.ravel(value)]


class Squeeze(Copy):
    """Drop size-1 axes (the listed ones, or all)."""

    static_inputs = frozenset({1})

    def shape(self, node: Node) -> tuple[int, ...]:
        source = node.input(0).shape
        axes = _axes(node)
        if axes is None:
            return tuple(d for d in source if d != 1)
        drop = {node.axis(a, len(source)) for a in axes}
        if any(source[a] != 1 for a in drop):
            raise node.fail(f"cannot squeeze axes {axes} of shape {source}")
        return tuple(d for i, d in enumerate(source) if i not in drop)


class Unsqueeze(Copy):
    """Insert size-1 axes at the listed output positions."""

    static_inputs = frozenset({1})

    def shape(self, node: Node) -> tuple[int, ...]:
        source = node.input(0).shape
        axes = _axes(node)
        if axes is None:
            raise node.fail("axes are required")
        rank = len(source) + len(axes)
        inserted = {node.axis(a, rank) for a in axes}
        rest = iter(source)
        return tuple(1 if i in inserted else next(rest) for i in range(rank))


class Transpose(Linear):
    """Permute axes (reversed when `perm` is absent)."""

    def _perm(self, node: Node) -> list[int]:
        rank = len(node.input(0).shape)
        perm = node.attr("perm")
        perm = list(range(rank))[::-1] if perm is None else [node.axis(p, rank) for p in perm]
        if sorted(perm) != list(range(rank)):
            raise node.fail(f"perm {perm} is not a permutation of {rank} axes")
        return perm

    def infer(self, node: Node) -> list[TensorType]:
        shape = node.input(0).shape
        return [(node.runtime_dtype(0), tuple(shape[p] for p in self._perm(node)))]

    def body(self, node: Node, params: Params) -> list[str]:
        strides = contiguous_strides(node.input(0).shape)
        access = Access(0, tuple(strides[p] for p in self._perm(node)))
        x, y = params.x[0], params.y[0]
        return loop_nest(node.outputs[0].shape, [access], lambda idx, out: f"{y}[{out}] = {x}[{idx[0]}];")


class Concat(Linear):
    """Join inputs along `axis`, copying each block of each input into place."""

    def _axis(self, node: Node) -> int:
        return node.axis(node.attr("axis"), len(node.input(0).shape))

    def infer(self, node: Node) -> list[TensorType]:
        first = node.input(0)
        dtype = node.runtime_dtype(0)
        axis = self._axis(node)
        total = 0
        for index in range(len(node.inputs)):
            tensor = node.input(index)
            if node.runtime_dtype(index) != dtype:
                raise node.fail("inputs have different dtypes")
            other = tensor.shape[:axis] + tensor.shape[axis + 1 :]
            if len(tensor.shape) != len(first.shape) or other != first.shape[:axis] + first.shape[axis + 1 :]:
                raise node.fail(f"shapes {first.shape} and {tensor.shape} differ outside axis {axis}")
            total += tensor.shape[axis]
        return [(dtype, first.shape[:axis] + (total,) + first.shape[axis + 1 :])]

    def body(self, node: Node, params: Params) -> list[str]:
        axis = self._axis(node)
        out = node.outputs[0].shape
        outer, inner = math.prod(out[:axis]), math.prod(out[axis + 1 :])
        row = out[axis] * inner
        lines, start = [], 0
        for index, name in enumerate(params.x):
            block = node.input(index).shape[axis] * inner
            if outer == 1:
                target, source = f"{start} + j" if start else "j", "j"
            else:
                target, source = f"{row} * o + {start} + j", f"{block} * o + j"
            copy = f"        {params.y[0]}[{target}] = {name}[{source}];"
            lines += [f"    for (int j = 0; j < {block}; ++j) {{", copy, "    }"]
            start += block
        if outer == 1:
            return [line[4:] for line in lines]
        return [f"for (int o = 0; o < {outer}; ++o) {{", *lines, "}"]


class Slice(Linear):
    """Slice with constant starts/ends/axes/steps (inputs since opset 10, attributes before)."""

    static_inputs = frozenset({1, 2, 3, 4})

    def _ranges(self, node: Node) -> list[range]:
        shape = node.input(0).shape
        if node.opset < 10:
            starts, ends, axes, steps = node.attr("starts"), node.attr("ends"), node.attr("axes"), None
        else:
            starts, ends, axes, steps = (node.static(i) for i in (1, 2, 3, 4))
        starts = [int(v) for v in np.ravel(starts)]
        ends = [int(v) for v in np.ravel(ends)]
        axes = list(range(len(starts))) if axes is None else [node.axis(int(a), len(shape)) for a in np.ravel(axes)]
        steps = [1] * len(starts) if steps is None else [int(v) for v in np.ravel(steps)]
        if not len(starts) == len(ends) == len(axes) == len(steps) or 0 in steps:
            raise node.fail("starts, ends, axes and steps must have equal lengths and non-zero steps")
        ranges = [range(dim) for dim in shape]
        for start, end, axis, step in zip(starts, ends, axes, steps):
            ranges[axis] = range(*slice(start, end, step).indices(shape[axis]))
        return ranges

    def infer(self, node: Node) -> list[TensorType]:
        return [(node.runtime_dtype(0), tuple(len(r) for r in self._ranges(node)))]

    def body(self, node: Node, params: Params) -> list[str]:
        ranges = self._ranges(node)
        strides = contiguous_strides(node.input(0).shape)
        offset = sum(r.start * s for r, s in zip(ranges, strides))
        access = Access(offset, tuple(r.step * s for r, s in zip(ranges, strides)))
        x, y = params.x[0], params.y[0]
        return loop_nest(node.outputs[0].shape, [access], lambda idx, out: f"{y}[{out}] = {x}[{idx[0]}];")


class Gather(Linear):
    """Gather along an axis with indices known when the C is generated."""

    static_inputs = frozenset({1})

    def _indices(self, node: Node) -> np.ndarray:
        indices = node.static(1)
        if indices is None or indices.dtype.kind not in "iu":
            raise node.fail("indices must be a constant integer tensor")
        dim = node.input(0).shape[self._axis(node)]
        if np.any((indices < -dim) | (indices >= dim)):
            raise node.fail(f"indices {indices.ravel().tolist()} out of range for dimension {dim}")
        return np.where(indices < 0, indices + dim, indices).astype(np.int64)

    def _axis(self, node: Node) -> int:
        return node.axis(node.attr("axis", 0), len(node.input(0).shape))

    def infer(self, node: Node) -> list[TensorType]:
        shape, axis = node.input(0).shape, self._axis(node)
        return [(node.runtime_dtype(0), shape[:axis] + self._indices(node).shape + shape[axis + 1 :])]

    def body(self, node: Node, params: Params) -> list[str]:
        shape, axis = node.input(0).shape, self._axis(node)
        indices = self._indices(node).ravel()
        outer, inner = math.prod(shape[:axis]), math.prod(shape[axis + 1 :])
        x, y = params.x[0], params.y[0]
        table = ", ".join(str(int(i) * inner) for i in indices)
        target, source = f"({indices.size} * o + g) * {inner} + j", f"{shape[axis] * inner} * o + source[g] + j"
        return [
            f"static const int source[{indices.size}] = {{{table}}};",
            f"for (int o = 0; o < {outer}; ++o) {{",
            f"    for (int g = 0; g < {indices.size}; ++g) {{",
            f"        for (int j = 0; j < {inner}; ++j) {{",
            f"            {y}[{target}] = {x}[{source}];",
            "        }",
            "    }",
            "}",
        ]


EMITTERS: dict[str, Linear] = {
    "Identity": Copy(),
    "Reshape": Reshape(),
    "Flatten": Flatten(),
    "Squeeze": Squeeze(),
    "Unsqueeze": Unsqueeze(),
    "Transpose": Transpose(),
    "Concat": Concat(),
    "Slice": Slice(),
    "Gather": Gather(),
}
