"""The one error the C generator raises for graphs it cannot translate, with a hint at the fallback backend."""

from __future__ import annotations

from nnfmu.errors import NnfmuError

FALLBACK_HINT = "build this graph with `--backend pythonfmu` instead"


class UnsupportedGraphError(NnfmuError, ValueError):
    """A graph, node or tensor the native backend cannot translate to C; names the op and node where known."""

    def __init__(self, reason: str, *, op_type: str | None = None, node_name: str | None = None) -> None:
        self.reason = reason
        self.op_type = op_type
        self.node_name = node_name
        where = ""
        if op_type is not None:
            shown = repr(node_name) if node_name else "(unnamed)"
            where = f"node {shown} (op {op_type}): "
        super().__init__(f"native C backend: {where}{reason}; {FALLBACK_HINT}")
