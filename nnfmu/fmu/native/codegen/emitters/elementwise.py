"""Element-wise operators: unary activations, broadcasting binary arithmetic, Clip and float casts, with their tangent
rules. At a kink the one-sided derivative the primal branch takes is used: Relu and Abs have derivative 0 at 0 (as
torch's autograd), Clip follows the bound it returns (bound's tangent when clipped, else the input's)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from onnx import TensorProto

from nnfmu.fmu.native.codegen.emitters.base import Emitter, Linear, Node, Params, TangentParams, TensorType
from nnfmu.fmu.native.codegen.emitters.loops import broadcast_access, loop_nest
from nnfmu.fmu.native.codegen.tensors import c_literal, math_fn

UnaryFormula = Callable[[str, np.dtype, Node], str]
# f'(x) dx as C from the expressions of x, y = f(x) and dx, the dtype and the node
TangentFormula = Callable[[str, str, str, np.dtype, Node], str]


class Unary(Emitter):
    """y = f(x) element by element; `formula(x expression, dtype, node)` gives f as C, `derivative` dy from dx."""

    def __init__(self, formula: UnaryFormula, derivative: TangentFormula) -> None:
        self.formula = formula
        self.derivative = derivative

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

    def tangent(self, node: Node, params: TangentParams) -> list[str] | None:
        tensor = node.input(0)
        expression = self.derivative("v", "w", "dv", tensor.dtype, node)
        return [
            f"for (int i = 0; i < {tensor.size}; ++i) {{",
            f"    const {tensor.ctype} v = {params.x[0]}[i];",
            f"    const {tensor.ctype} w = {params.y[0]}[i];",
            f"    const {tensor.ctype} dv = {params.dx[0]}[i];",
            "    (void)v;",
            "    (void)w;",
            f"    {params.dy[0]}[i] = {expression};",
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


def _d_abs(v: str, w: str, dv: str, dtype: np.dtype, node: Node) -> str:
    zero = c_literal(0.0, dtype)
    return f"{v} > {zero} ? {dv} : ({v} < {zero} ? -{dv} : {zero})"


def _d_sqrt(v: str, w: str, dv: str, dtype: np.dtype, node: Node) -> str:
    """dv / (2 sqrt(x)); a zero tangent stays zero at x = 0 (where the derivative is infinite)."""
    zero = c_literal(0.0, dtype)
    return f"{dv} == {zero} ? {zero} : {dv} / ({c_literal(2.0, dtype)} * {w})"


def _d_relu(v: str, w: str, dv: str, dtype: np.dtype, node: Node) -> str:
    zero = c_literal(0.0, dtype)
    return f"{v} > {zero} ? {dv} : {zero}"


def _d_leaky_relu(v: str, w: str, dv: str, dtype: np.dtype, node: Node) -> str:
    alpha = c_literal(node.attr("alpha", 0.01), dtype)
    return f"{v} >= {c_literal(0.0, dtype)} ? {dv} : {alpha} * {dv}"


def _d_softplus(v: str, w: str, dv: str, dtype: np.dtype, node: Node) -> str:
    one = c_literal(1.0, dtype)
    return f"{dv} / ({one} + {math_fn('exp', dtype)}(-{v}))"


UNARY: dict[str, tuple[UnaryFormula, TangentFormula]] = {
    "Neg": (lambda v, dtype, node: f"-{v}", lambda v, w, dv, dtype, node: f"-{dv}"),
    "Abs": (_call("fabs"), _d_abs),
    "Exp": (_call("exp"), lambda v, w, dv, dtype, node: f"{w} * {dv}"),
    "Log": (_call("log"), lambda v, w, dv, dtype, node: f"{dv} / {v}"),
    "Sqrt": (_call("sqrt"), _d_sqrt),
    "Tanh": (_call("tanh"), lambda v, w, dv, dtype, node: f"({c_literal(1.0, dtype)} - {w} * {w}) * {dv}"),
    "Sigmoid": (_sigmoid, lambda v, w, dv, dtype, node: f"{w} * ({c_literal(1.0, dtype)} - {w}) * {dv}"),
    "Relu": (_relu, _d_relu),
    "LeakyRelu": (_leaky_relu, _d_leaky_relu),
    "Softplus": (_softplus, _d_softplus),
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

    def tangent(self, node: Node, params: TangentParams) -> list[str] | None:
        """Sum and product rules; terms of a constant operand (zero tangent) are left out."""
        shape = node.outputs[0].shape
        accesses = [broadcast_access(node.input(i).shape, shape) for i in (0, 1)]
        a, b = params.x
        da, db = params.dx
        zero = c_literal(0.0, node.input(0).dtype)

        def statement(idx: list[str], out: str) -> str:
            x_a, x_b = f"{a}[{idx[0]}]", f"{b}[{idx[1]}]"
            d_a = f"{da}[{idx[0]}]" if da else None
            d_b = f"{db}[{idx[1]}]" if db else None
            terms = {
                "+": [d_a, d_b],
                "-": [d_a, f"-{d_b}" if d_b else None],
                "*": [f"{d_a} * {x_b}" if d_a else None, f"{x_a} * {d_b}" if d_b else None],
                "/": [f"{d_a} / {x_b}" if d_a else None, f"-{x_a} * {d_b} / ({x_b} * {x_b})" if d_b else None],
            }[self.operator]
            return f"{params.dy[0]}[{out}] = {' + '.join(t for t in terms if t) or zero};"

        return loop_nest(shape, accesses, statement)


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

    def tangent(self, node: Node, params: TangentParams) -> list[str] | None:
        """The tangent of what is returned: a bound's (zero for a constant one) where clipped, else the input's."""
        tensor = node.input(0)
        zero = c_literal(0.0, tensor.dtype)
        dx = f"{params.dx[0]}[i]" if params.dx[0] else zero
        if node.opset < 11:
            low = c_literal(node.attr("min", -np.inf), tensor.dtype)
            high = c_literal(node.attr("max", np.inf), tensor.dtype)
            bounds = [(low, zero), (high, zero)]
        else:
            bounds = [
                (f"{params.x[i]}[0]", f"{params.dx[i]}[0]" if params.dx[i] else zero) if params.x[i] else (None, None)
                for i in (1, 2)
            ]
        (low, d_low), (high, d_high) = bounds
        lines = [
            f"for (int i = 0; i < {tensor.size}; ++i) {{",
            f"    {tensor.ctype} v = {params.x[0]}[i];",
            f"    {tensor.ctype} dv = {dx};",
        ]
        if low is not None:
            lines.append(f"    if (v < {low}) {{ v = {low}; dv = {d_low}; }}")
        if high is not None:
            lines.append(f"    if (v > {high}) {{ v = {high}; dv = {d_high}; }}")
        return [*lines, "    (void)v;", f"    {params.dy[0]}[i] = dv;", "}"]


class Cast(Linear):
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
    **{op: Unary(formula, derivative) for op, (formula, derivative) in UNARY.items()},
    "Add": Binary("+"),
    "Sub": Binary("-"),
    "Mul": Binary("*"),
    "Div": Binary("/"),
    "Clip": Clip(),
    "Cast": Cast(),
}
