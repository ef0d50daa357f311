"""Element-wise operators: unary activations, broadcasting binary arithmetic, Clip and float casts."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from onnx import TensorProto

from nnfmu.fmu.native.codegen.emitters.base import Emitter, Node, Params, TensorType
from nnfmu.fmu.native.codegen.emitters.loops import broadcast_access, loop_nest
from nnfmu.fmu.native.codegen.tensors import c_literal, math_fn

UnaryFormula = Callable[[str, np.dtype, Node], str]


class Unary(Emitter):
    """y = f(x) element by element; `formula(x expression, dtype, node)` gives f as C."""

    def __init__(self, formula: UnaryFormula) -> None:
        self.formula = formula

    def infer(self, node: Node) -> list[TensorType]:
        return [(node.runtime_dtype(0), node.input(0).shape)]

    def body(self, node: Node, params: Params) -> list[str]:
        x, y = params.x[0], params.y[0]
        tensor = node.input(0)
        expression = self.formula("v", tensor.dtype, node)
        return [
            f"for (int i = 0; i < {tensor.size}; ++i) {{",
            f"    const {tensor.ctype} v = {x}[i];",
            f"    {y}[i] = {expression};",
            "}",
        ]


def _call(function: str) -> UnaryFormula:
    return lambda v, dtype, node: f"{math_fn(function, dtype)}({v})"


def _sigmoid(v: str, dtype: np.dtype, node: Node) -> str:
    one = c_literal(1.0, dtype)
    return f"{one} / ({one} + {math_fn('exp', dtype)}(-{v}))"


def _relu(v: str, dtype: np.dtype, node: Node) -> str:
    return f"{v} > {c_literal(0.0, dtype)} ? {v} : {c_literal(0.0, dtype)}"


def _leaky_relu(v: str, dtype: np.dtype, node: Node) -> str:
    alpha = c_literal(node.attr("alpha", 0.01), dtype)
    return f"{v} >= {c_literal(0.0, dtype)} ? {v} : {alpha} * {v}"


def _softplus(v: str, dtype: np.dtype, node: Node) -> str:
    exp, log1p, zero = math_fn("exp", dtype), math_fn("log1p", dtype), c_literal(0.0, dtype)
    return f"{v} > {zero} ? {v} + {log1p}({exp}(-{v})) : {log1p}({exp}({v}))"


UNARY: dict[str, UnaryFormula] = {
    "Neg": lambda v, dtype, node: f"-{v}",
    "Abs": _call("fabs"),
    "Exp": _call("exp"),
    "Log": _call("log"),
    "Sqrt": _call("sqrt"),
    "Tanh": _call("tanh"),
    "Sigmoid": _sigmoid,
    "Relu": _relu,
    "LeakyRelu": _leaky_relu,
    "Softplus": _softplus,
}


class Binary(Emitter):
    """y = a <op> b with numpy broadcasting."""

    def __init__(self, operator: str) -> None:
        self.operator = operator

    def infer(self, node: Node) -> list[TensorType]:
        a, b = node.input(0), node.input(1)
        if node.runtime_dtype(0) != node.runtime_dtype(1):
            raise node.fail(f"operands have different dtypes {a.dtype} and {b.dtype}")
        try:
            shape = np.broadcast_shapes(a.shape, b.shape)
        except ValueError as err:
            raise node.fail(f"shapes {a.shape} and {b.shape} do not broadcast") from err
        return [(a.dtype, tuple(shape))]

    def body(self, node: Node, params: Params) -> list[str]:
        shape = node.outputs[0].shape
        accesses = [broadcast_access(node.input(i).shape, shape) for i in (0, 1)]
        a, b, y = params.x[0], params.x[1], params.y[0]
        return loop_nest(shape, accesses, lambda idx, out: f"{y}[{out}] = {a}[{idx[0]}] {self.operator} {b}[{idx[1]}];")


class Clip(Emitter):
    """y = min(max(x, min), max); bounds from attributes (opset < 11) or optional scalar inputs."""

    def infer(self, node: Node) -> list[TensorType]:
        dtype = node.runtime_dtype(0)
        for index in (1, 2):
            bound = node.optional(index)
            if bound is not None and (bound.size != 1 or bound.dtype != dtype):
                raise node.fail(f"bound input {index} must be a scalar of dtype {dtype}")
        return [(dtype, node.input(0).shape)]

    def body(self, node: Node, params: Params) -> list[str]:
        x, y = params.x[0], params.y[0]
        tensor = node.input(0)
        if node.opset < 11:
            low = c_literal(node.attr("min", -np.inf), tensor.dtype)
            high = c_literal(node.attr("max", np.inf), tensor.dtype)
        else:
            low = f"{params.x[1]}[0]" if params.x[1] else None
            high = f"{params.x[2]}[0]" if params.x[2] else None
        lines = [f"for (int i = 0; i < {tensor.size}; ++i) {{", f"    {tensor.ctype} v = {x}[i];"]
        if low is not None:
            lines.append(f"    if (v < {low}) v = {low};")
        if high is not None:
            lines.append(f"    if (v > {high}) v = {high};")
        return [*lines, f"    {y}[i] = v;", "}"]


class Cast(Emitter):
    """Conversion between float32 and float64."""

    TARGETS = {TensorProto.FLOAT: np.dtype(np.float32), TensorProto.DOUBLE: np.dtype(np.float64)}

    def infer(self, node: Node) -> list[TensorType]:
        node.runtime_dtype(0)
        target = self.TARGETS.get(node.attr("to"))
        if target is None:
            raise node.fail(f"cast to ONNX type {node.attr('to')} is not supported (only float and double)")
        return [(target, node.input(0).shape)]

    def body(self, node: Node, params: Params) -> list[str]:
        output = node.outputs[0]
        conversion = f"    {params.y[0]}[i] = ({output.ctype}){params.x[0]}[i];"
        return [f"for (int i = 0; i < {output.size}; ++i) {{", conversion, "}"]


EMITTERS: dict[str, Emitter] = {
    **{op: Unary(formula) for op, formula in UNARY.items()},
    "Add": Binary("+"),
    "Sub": Binary("-"),
    "Mul": Binary("*"),
    "Div": Binary("/"),
    "Clip": Clip(),
    "Cast": Cast(),
}
