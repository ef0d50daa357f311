"""The registry {ONNX op type: emitter}; adding an operator means an emitter, an entry here and a test."""

from __future__ import annotations

from nnfmu.fmu.native.codegen.emitters import elementwise, linear, recurrent, shaping
from nnfmu.fmu.native.codegen.emitters.base import Emitter, Node

EMITTERS: dict[str, Emitter] = {
    **elementwise.EMITTERS,
    **linear.EMITTERS,
    **shaping.EMITTERS,
    **recurrent.EMITTERS,
}
SUPPORTED_OPS: tuple[str, ...] = tuple(sorted(EMITTERS))


def emitter_for(node: Node) -> Emitter:
    """The emitter of `node`'s operator; an error naming op and node when there is none."""
    emitter = EMITTERS.get(node.op_type) if node.proto.domain in ("", "ai.onnx") else None
    if emitter is None:
        domain = f" in domain {node.proto.domain!r}" if node.proto.domain not in ("", "ai.onnx") else ""
        raise node.fail(f"operator{domain} is not supported by the C generator (supported: {', '.join(SUPPORTED_OPS)})")
    return emitter
