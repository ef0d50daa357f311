"""C code generated from an ONNX graph: one emitter per operator, static weights, one re-entrant run function."""

from nnfmu.fmu.native.codegen.errors import UnsupportedGraphError
from nnfmu.fmu.native.codegen.generate import GeneratedGraph, generate_c
from nnfmu.fmu.native.codegen.registry import SUPPORTED_OPS

__all__ = ["GeneratedGraph", "SUPPORTED_OPS", "UnsupportedGraphError", "generate_c"]
