"""Print graph.h and graph.c from a StaticGraph: weights, one static function per node, the run function, and, when
every node has a tangent rule, one tangent function per node and the forward-mode derivative function `_graph_jvp`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu import __version__
from nnfmu.fmu.native.codegen.cnames import NameTable, comment_text
from nnfmu.fmu.native.codegen.emitters.base import Params, TangentParams
from nnfmu.fmu.native.codegen.errors import UnsupportedGraphError
from nnfmu.fmu.native.codegen.graph import StaticGraph, Step
from nnfmu.fmu.native.codegen.tensors import RUNTIME_DTYPES, Tensor, c_literal

STACK_LIMIT_BYTES = 256 * 1024
VALUES_PER_LINE = 4
SPECIAL_VALUES = [
    "/* Infinities and NaNs of initializers, as C99 <math.h> constant expressions. */",
    "#define CG_INF ((double)INFINITY)",
    "#define CG_NAN ((double)NAN)",
    "#define CG_INFF INFINITY",
    "#define CG_NANF NAN",
]


@dataclass(frozen=True)
class Layout:
    """Where each boundary tensor lies in the flat `in`/`out` arrays."""

    offsets: list[int]
    total: int


def layout(tensors: list[Tensor]) -> Layout:
    """Consecutive offsets of `tensors` in one flat array."""
    offsets, total = [], 0
    for tensor in tensors:
        offsets.append(total)
        total += tensor.size
    return Layout(offsets, total)


def quoted(text: str) -> str:
    """`text` in double quotes, safe inside a C comment."""
    return '"' + comment_text(text).replace('"', '\\"') + '"'


def describe(tensor: Tensor) -> str:
    """`"name" float64[1, 3]` for comments."""
    return f"{quoted(tensor.name)} {tensor.dtype.name}[{', '.join(map(str, tensor.shape))}]"


class SourceWriter:
    """Assigns C names to tensors and prints the two files."""

    def __init__(self, graph: StaticGraph, prefix: str, producer: str) -> None:
        self.graph = graph
        self.prefix = prefix
        self.producer = producer
        self.names = NameTable()
        self.cnames: dict[str, str] = {}  # ONNX tensor name -> C identifier
        self.weights: list[Tensor] = []  # constants the C reads, in order of first use
        self.jvp_missing: str | None = "graph.c not written yet"  # why graph.c has no `_graph_jvp`

    @property
    def has_jvp(self) -> bool:
        """Whether the source defines `<prefix>_graph_jvp` (call after `source()`)."""
        return self.jvp_missing is None

    def header(self) -> str:
        """graph.h: sizes of the flat in/out arrays, their layout as comments, the run function's prototype."""
        upper = self.prefix.upper()
        lines = [
            *self._banner("graph.h"),
            f"#ifndef {upper}_GRAPH_H",
            f"#define {upper}_GRAPH_H",
            "",
            *self._boundary_comment("in", self.graph.inputs),
            f"#define {upper}_N_IN {layout(self.graph.inputs).total}",
            *self._boundary_comment("out", self.graph.outputs),
            f"#define {upper}_N_OUT {layout(self.graph.outputs).total}",
            "",
            "/* Evaluate the graph once: in[] holds all inputs, out[] receives all outputs (row-major, concatenated",
            " * in graph order). Re-entrant: intermediate tensors live on the caller's stack, weights are read-only.",
            " * Returns 0 on success, 1 when a pointer is NULL. */",
            f"int {self.prefix}_graph_run(const double *in, double *out);",
            "",
            "/* 1 when graph.c defines the forward-mode derivative below (every node has a tangent rule). */",
            f"#define {upper}_HAS_JVP {int(self.has_jvp)}",
            f"#if {upper}_HAS_JVP",
            "/* The graph at in[] (outputs to out[], as the run function) and its directional derivative:",
            " * out_dot[] = J(in) in_dot[], J the Jacobian of all outputs with respect to all inputs, exact up to",
            " * rounding. At a kink (Relu, Abs, Clip at a bound) the derivative of the branch the evaluation takes;",
            " * sqrt at 0 passes a zero tangent as zero. Re-entrant like the run function. Returns 0 on success, 1",
            " * when a pointer is NULL. */",
            f"int {self.prefix}_graph_jvp(const double *in, const double *in_dot, double *out, double *out_dot);",
            "#endif",
            "",
            f"#endif /* {upper}_GRAPH_H */",
        ]
        return "\n".join(lines) + "\n"

    def source(self) -> str:
        """graph.c: weights, one static function per node, then `<prefix>_graph_run` calling them in order."""
        self.names, self.cnames, self.weights = NameTable(), {}, []
        functions = [self._function(step) for step in self.graph.steps]
        run = self._run(functions)
        tangents = [self._tangent_function(step) for step in self.graph.steps]
        jvp: list[str] = []
        missing = [step for step, tangent in zip(self.graph.steps, tangents) if tangent is None]
        self.jvp_missing = None
        if missing:
            node = missing[0].node
            self.jvp_missing = f"node {node.name!r} (op {node.op_type}) has no tangent rule"
        else:
            try:
                jvp = self._jvp(functions, [t for t in tangents if t is not None])
            except UnsupportedGraphError as err:
                self.jvp_missing = err.reason
        lines = [*self._banner("graph.c"), "#include <math.h>", "", '#include "graph.h"', "", *SPECIAL_VALUES, ""]
        for tensor in self.weights:
            lines += self._weight(tensor)
        for _, text in functions:
            lines += text
        if not self.jvp_missing:
            for _, text in tangents:
                lines += text
        return "\n".join(lines + run + ([""] + jvp if jvp else [])) + "\n"

    def _banner(self, file: str) -> list[str]:
        return [
            f"/* {file}: generated by nnfmu {__version__} (native C code generator); do not edit.",
            f" * Source: ONNX graph {quoted(self.graph.name)} made by {quoted(self.producer)}. */",
            "",
        ]

    def _boundary_comment(self, array: str, tensors: list[Tensor]) -> list[str]:
        lines = []
        for tensor, offset in zip(tensors, layout(tensors).offsets):
            lines.append(f"/* {array}[{offset}..{offset + tensor.size - 1}]: {describe(tensor)} */")
        return lines

    def _tensor(self, tensor: Tensor) -> str:
        """The C name of a tensor; constants become static const weight arrays on first use."""
        name = self.cnames.get(tensor.name)
        if name is None:
            kind = "w" if tensor.is_constant else "t"
            name = self.cnames[tensor.name] = self.names.make(kind, tensor.name)
            if tensor.is_constant:
                if tensor.dtype not in RUNTIME_DTYPES:
                    tensor = Tensor(tensor.name, np.dtype(np.float64), tensor.shape, tensor.value.astype(np.float64))
                self.weights.append(tensor)
        return name

    def _weight(self, tensor: Tensor) -> list[str]:
        values = [c_literal(v, tensor.dtype) for v in np.ravel(tensor.value)]
        rows = [", ".join(values[i : i + VALUES_PER_LINE]) for i in range(0, len(values), VALUES_PER_LINE)]
        return [
            f"/* ONNX constant {describe(tensor)} */",
            f"static const {tensor.ctype} {self.cnames[tensor.name]}[{tensor.size}] = {{",
            *(f"    {row}," for row in rows),
            "};",
            "",
        ]

    def _function(self, step: Step) -> tuple[str, list[str]]:
        node = step.node
        name = self.names.make("node", f"{node.op_type}_{node.name}")
        x: list[str | None] = [None] * len(node.inputs)
        declared = []
        for index in step.data_inputs:
            x[index] = f"x{index}"
            declared.append(f"const {node.inputs[index].ctype} *x{index}")
        y: list[str | None] = [None if t is None else f"y{j}" for j, t in enumerate(node.outputs)]
        declared += [f"{t.ctype} *y{j}" for j, t in enumerate(node.outputs) if t is not None]
        body = step.emitter.body(node, Params(x, y))
        inputs = ", ".join(describe(node.inputs[i]) for i in step.data_inputs)
        outputs = ", ".join(describe(t) for t in node.outputs if t is not None)
        text = [
            f"/* ONNX {comment_text(node.op_type)} node {quoted(node.name)}: {inputs} -> {outputs} */",
            f"static void {name}({', '.join(declared)})",
            "{",
            *("    " + line for line in body),
            "}",
            "",
        ]
        return name, text

    def _tangent_function(self, step: Step) -> tuple[str, list[str]] | None:
        """The node's tangent function `(x..., y..., dx... of run-time inputs, dy...)`, or None without a rule."""
        node = step.node
        x: list[str | None] = [None] * len(node.inputs)
        dx: list[str | None] = [None] * len(node.inputs)
        declared, unused = [], []
        for index in step.data_inputs:
            x[index] = f"x{index}"
            declared.append(f"const {node.inputs[index].ctype} *x{index}")
            unused.append(f"x{index}")
        y: list[str | None] = [None if t is None else f"y{j}" for j, t in enumerate(node.outputs)]
        declared += [f"const {t.ctype} *y{j}" for j, t in enumerate(node.outputs) if t is not None]
        unused += [f"y{j}" for j, t in enumerate(node.outputs) if t is not None]
        for index in step.data_inputs:
            if not node.inputs[index].is_constant:
                dx[index] = f"dx{index}"
                declared.append(f"const {node.inputs[index].ctype} *dx{index}")
                unused.append(f"dx{index}")
        dy: list[str | None] = [None if t is None else f"dy{j}" for j, t in enumerate(node.outputs)]
        declared += [f"{t.ctype} *dy{j}" for j, t in enumerate(node.outputs) if t is not None]
        body = step.emitter.tangent(node, TangentParams(x, y, dx, dy))
        if body is None:
            return None
        name = self.names.make("tangent", f"{node.op_type}_{node.name}")
        text = [
            f"/* Tangent of ONNX {comment_text(node.op_type)} node {quoted(node.name)}: dy from dx at x, y. */",
            f"static void {name}({', '.join(declared)})",
            "{",
            *(f"    (void){param};" for param in unused),
            *("    " + line for line in body),
            "}",
            "",
        ]
        return name, text

    def _jvp(self, functions: list[tuple[str, list[str]]], tangents: list[tuple[str, list[str]]]) -> list[str]:
        """`<prefix>_graph_jvp`: every node and then its tangent, in order; tangents of constants are zero and not
        passed. Raises UnsupportedGraphError when the tensors and their tangents need too much stack."""
        graph = self.graph
        lines = ["    if (in == 0 || in_dot == 0 || out == 0 || out_dot == 0) {", "        return 1;", "    }"]
        stack = self._bind_inputs(lines, (("in", ""), ("in_dot", "d_")))
        for step, (function, _), (tangent, _) in zip(graph.steps, functions, tangents):
            inputs = [self._tensor(step.node.inputs[i]) for i in step.data_inputs]
            d_inputs = [
                f"d_{self._tensor(step.node.inputs[i])}"
                for i in step.data_inputs
                if not step.node.inputs[i].is_constant
            ]
            outputs, d_outputs = [], []
            for tensor in step.node.outputs:
                if tensor is not None:
                    name = self._tensor(tensor)
                    stack += 2 * tensor.size * tensor.dtype.itemsize
                    lines.append(f"    {tensor.ctype} {name}[{tensor.size}]; /* {describe(tensor)} */")
                    lines.append(f"    {tensor.ctype} d_{name}[{tensor.size}];")
                    outputs.append(name)
                    d_outputs.append(f"d_{name}")
            lines.append(f"    {function}({', '.join(inputs + outputs)});")
            lines.append(f"    {tangent}({', '.join(inputs + outputs + d_inputs + d_outputs)});")
        for tensor, offset in zip(graph.outputs, layout(graph.outputs).offsets):
            name = self._tensor(tensor)
            d_value = "0.0" if tensor.is_constant else f"(double)d_{name}[i]"
            lines.append(f"    for (int i = 0; i < {tensor.size}; ++i) {{ /* {describe(tensor)} */")
            lines.append(f"        out[{offset} + i] = (double){name}[i];")
            lines.append(f"        out_dot[{offset} + i] = {d_value};")
            lines.append("    }")
        if stack > STACK_LIMIT_BYTES:
            raise UnsupportedGraphError(
                f"the derivative's tensors and tangents need {stack} bytes of stack, more than the "
                f"{STACK_LIMIT_BYTES} bytes allowed"
            )
        signature = [
            f"/* Runs every node and its tangent in order. Tensors and tangents: {stack} bytes on the stack. */",
            f"int {self.prefix}_graph_jvp(const double *in, const double *in_dot, double *out, double *out_dot)",
            "{",
        ]
        return [*signature, *lines, "    return 0;", "}"]

    def _bind_inputs(self, lines: list[str], arrays: tuple[tuple[str, str], ...]) -> int:
        """Append the C that names each used graph input inside each of `arrays` ((C array, name prefix): a float64
        tensor points into it, another is copied to a local of its type); return the stack bytes the copies take."""
        graph = self.graph
        stack = 0
        used = {step.node.inputs[i].name for step in graph.steps for i in step.data_inputs}
        used.update(tensor.name for tensor in graph.outputs)
        for tensor, offset in zip(graph.inputs, layout(graph.inputs).offsets):
            if tensor.name not in used:
                continue
            for array, prefix in arrays:
                cname = f"{prefix}{self._tensor(tensor)}"
                if tensor.dtype == np.float64:
                    lines.append(f"    const double *const {cname} = {array} + {offset}; /* {describe(tensor)} */")
                else:
                    stack += tensor.size * tensor.dtype.itemsize
                    lines.append(f"    {tensor.ctype} {cname}[{tensor.size}]; /* {describe(tensor)} */")
                    lines.append(f"    for (int i = 0; i < {tensor.size}; ++i) {{")
                    lines.append(f"        {cname}[i] = ({tensor.ctype}){array}[{offset} + i];")
                    lines.append("    }")
        return stack

    def _run(self, functions: list[tuple[str, list[str]]]) -> list[str]:
        graph = self.graph
        lines = ["    if (in == 0 || out == 0) {", "        return 1;", "    }"]
        stack = self._bind_inputs(lines, (("in", ""),))
        for step, (function, _) in zip(graph.steps, functions):
            arguments = [self._tensor(step.node.inputs[i]) for i in step.data_inputs]
            for tensor in step.node.outputs:
                if tensor is not None:
                    name = self._tensor(tensor)
                    stack += tensor.size * tensor.dtype.itemsize
                    lines.append(f"    {tensor.ctype} {name}[{tensor.size}]; /* {describe(tensor)} */")
                    arguments.append(name)
            lines.append(f"    {function}({', '.join(arguments)});")
        for tensor, offset in zip(graph.outputs, layout(graph.outputs).offsets):
            name = self._tensor(tensor)
            lines.append(f"    for (int i = 0; i < {tensor.size}; ++i) {{ /* {describe(tensor)} */")
            lines.append(f"        out[{offset} + i] = (double){name}[i];")
            lines.append("    }")
        if stack > STACK_LIMIT_BYTES:
            raise UnsupportedGraphError(
                f"intermediate tensors need {stack} bytes of stack, more than the {STACK_LIMIT_BYTES} bytes allowed"
            )
        signature = [
            f"/* Runs every node in order. Tensors: {stack} bytes on the stack; no static or heap state, so",
            " * concurrent calls (many FMU instances in one process) are safe. */",
            f"int {self.prefix}_graph_run(const double *in, double *out)",
            "{",
        ]
        return [*signature, *lines, "    return 0;", "}"]
