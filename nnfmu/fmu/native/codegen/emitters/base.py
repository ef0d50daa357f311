"""The contract every operator emitter fulfils: infer output types/shapes, then print the body of a C function."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import onnx

from nnfmu.fmu.native.codegen.errors import UnsupportedGraphError
from nnfmu.fmu.native.codegen.tensors import RUNTIME_DTYPES, Tensor

TensorType = tuple[np.dtype, tuple[int, ...]]


@dataclass
class Node:
    """One ONNX node with its resolved input tensors (None where an optional input is omitted)."""

    proto: onnx.NodeProto
    opset: int
    inputs: list[Tensor | None]
    outputs: list[Tensor | None] = field(default_factory=list)

    @property
    def op_type(self) -> str:
        """The ONNX operator type."""
        return self.proto.op_type

    @property
    def name(self) -> str:
        """The node's name in the graph (may be empty)."""
        return self.proto.name

    def fail(self, reason: str) -> UnsupportedGraphError:
        """An error naming this node's op and name."""
        return UnsupportedGraphError(reason, op_type=self.op_type, node_name=self.name)

    def attr(self, name: str, default: Any = None) -> Any:
        """Attribute value (ints/floats/lists as Python values), or `default` when absent."""
        for attribute in self.proto.attribute:
            if attribute.name == name:
                value = onnx.helper.get_attribute_value(attribute)
                return value.decode() if isinstance(value, bytes) else value
        return default

    def input(self, index: int) -> Tensor:
        """A required input."""
        tensor = self.inputs[index] if index < len(self.inputs) else None
        if tensor is None:
            raise self.fail(f"required input {index} is missing")
        return tensor

    def optional(self, index: int) -> Tensor | None:
        """An optional input, None when omitted."""
        return self.inputs[index] if index < len(self.inputs) else None

    def static(self, index: int) -> np.ndarray | None:
        """The generation-time value of an optional input (shape/index tensors); None when omitted."""
        tensor = self.optional(index)
        if tensor is None:
            return None
        if tensor.value is None:
            raise self.fail(f"input {index} ({tensor.name!r}) must be a constant known when the C is generated")
        return tensor.value

    def runtime_dtype(self, index: int = 0) -> np.dtype:
        """The dtype of a run-time input, refusing anything but float32/float64."""
        dtype = self.input(index).dtype
        if dtype not in RUNTIME_DTYPES:
            raise self.fail(f"input {index} has dtype {dtype}; only float32 and float64 tensors are computed in C")
        return dtype

    def axis(self, value: int, rank: int) -> int:
        """A possibly negative axis normalised to [0, rank)."""
        if not -rank <= value < rank:
            raise self.fail(f"axis {value} out of range for rank {rank}")
        return value % rank


@dataclass(frozen=True)
class Params:
    """C parameter names of one node function: `x[i]` per data input, `y[j]` per output (None where absent)."""

    x: list[str | None]
    y: list[str | None]


@dataclass(frozen=True)
class TangentParams:
    """C parameter names of one node's tangent function: the primal data inputs `x` and outputs `y` (read only), the
    tangents `dx` of the data inputs (None for a constant input, whose tangent is zero) and `dy` of the outputs."""

    x: list[str | None]
    y: list[str | None]
    dx: list[str | None]
    dy: list[str | None]


class Emitter(ABC):
    """Translate one ONNX operator (or family) to C."""

    #: input positions whose values are needed at generation time (shapes, indices, axes); never C parameters
    static_inputs: frozenset[int] = frozenset()

    def skipped_inputs(self, node: Node) -> frozenset[int]:
        """Present inputs this node's result does not depend on (e.g. Gemm's C when beta = 0)."""
        return frozenset()

    @abstractmethod
    def infer(self, node: Node) -> list[TensorType]:
        """Output dtype and shape for each output of `node`."""

    @abstractmethod
    def body(self, node: Node, params: Params) -> list[str]:
        """Lines of the C function body computing the outputs from the data inputs."""

    def tangent(self, node: Node, params: TangentParams) -> list[str] | None:
        """Lines of the C function body computing the outputs' tangents (forward-mode derivative) from the inputs'
        tangents at the primal point `params.x`/`params.y`; None when the operator has no tangent rule."""
        return None


def zero_tangents(node: Node, params: TangentParams) -> tuple[list[str], list[str | None]]:
    """Declarations of all-zero arrays standing for the tangents of constant data inputs, and the tangent names of
    every input with those filled in (for rules that treat every operand alike)."""
    lines: list[str] = []
    names = list(params.dx)
    for index, name in enumerate(params.x):
        if name is not None and names[index] is None:
            tensor = node.input(index)
            lines.append(f"static const {tensor.ctype} zero{index}[{tensor.size}] = {{0}};")
            names[index] = f"zero{index}"
    return lines, names


class Linear(Emitter):
    """An operator linear in its data inputs (data movement, casts): its tangent is the operator applied to the
    inputs' tangents."""

    def tangent(self, node: Node, params: TangentParams) -> list[str] | None:
        zeros, names = zero_tangents(node, params)
        return zeros + self.body(node, Params(names, params.dy))
