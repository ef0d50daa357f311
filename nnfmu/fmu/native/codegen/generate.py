"""Entry point of the C generator: ONNX model in, graph.h/graph.c text and boundary sizes out."""

from __future__ import annotations

from dataclasses import dataclass

import onnx

from nnfmu.fmu.native.codegen.cnames import check_prefix
from nnfmu.fmu.native.codegen.graph import analyse
from nnfmu.fmu.native.codegen.writer import SourceWriter


@dataclass(frozen=True)
class GeneratedGraph:
    """The generated C and the element counts of the graph inputs/outputs (the `in`/`out` layout)."""

    header: str  # graph.h text
    source: str  # graph.c text
    input_sizes: list[int]  # element count of each graph input (non-initializer), in graph order
    output_sizes: list[int]  # element count of each graph output, in graph order
    jvp_missing: str | None = None  # why the source has no `<prefix>_graph_jvp` (a node without a tangent rule)

    @property
    def has_jvp(self) -> bool:
        """Whether the source defines the forward-mode derivative `<prefix>_graph_jvp`."""
        return self.jvp_missing is None


def generate_c(model: onnx.ModelProto, prefix: str = "nn") -> GeneratedGraph:
    """Translate `model` to C exposing `int <prefix>_graph_run(const double *in, double *out)` and, when every node
    has a tangent rule, its directional derivative `int <prefix>_graph_jvp(in, in_dot, out, out_dot)`.

    Raises UnsupportedGraphError (naming op and node) for anything the native backend cannot translate.
    """
    graph = analyse(model)
    producer = f"{model.producer_name} {model.producer_version}".strip() or "unknown producer"
    writer = SourceWriter(graph, check_prefix(prefix), producer)
    source = writer.source()
    return GeneratedGraph(
        header=writer.header(),
        source=source,
        input_sizes=[t.size for t in graph.inputs],
        output_sizes=[t.size for t in graph.outputs],
        jvp_missing=writer.jvp_missing,
    )
