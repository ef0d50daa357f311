"""What the generator knows about one tensor: dtype, static shape and, for constants, its value."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from onnx import TensorProto

# Element types a tensor may have in the generated C (run time) and the ones usable only at generation time.
RUNTIME_DTYPES = {np.dtype(np.float64): "double", np.dtype(np.float32): "float"}
ONNX_TO_NUMPY = {
    TensorProto.DOUBLE: np.dtype(np.float64),
    TensorProto.FLOAT: np.dtype(np.float32),
    TensorProto.INT64: np.dtype(np.int64),
    TensorProto.INT32: np.dtype(np.int32),
    TensorProto.BOOL: np.dtype(np.bool_),
}


@dataclass(frozen=True)
class Tensor:
    """One tensor of the graph; `value` is set when it is known at generation time (initializer or folded)."""

    name: str
    dtype: np.dtype
    shape: tuple[int, ...]
    value: np.ndarray | None = None

    @property
    def size(self) -> int:
        """Number of elements."""
        return math.prod(self.shape)

    @property
    def is_constant(self) -> bool:
        """Whether the value is known at generation time."""
        return self.value is not None

    @property
    def ctype(self) -> str:
        """C element type; only run-time tensors (float32/float64) have one."""
        return RUNTIME_DTYPES[self.dtype]


def constant(name: str, value: np.ndarray) -> Tensor:
    """A generation-time constant tensor."""
    value = np.asarray(value)
    return Tensor(name, value.dtype, tuple(int(d) for d in value.shape), value)


def c_literal(value: float, dtype: np.dtype) -> str:
    """A C literal of `dtype` holding `value` exactly (%.17g for double, %.9g float); inf/nan via macros."""
    value = float(value)
    suffix = "f" if dtype == np.float32 else ""
    if math.isnan(value):
        return f"CG_NAN{suffix.upper()}"
    if math.isinf(value):
        return f"{'-' if value < 0 else ''}CG_INF{suffix.upper()}"
    text = f"{value:.9g}" if dtype == np.float32 else f"{value:.17g}"
    if not any(c in text for c in ".e"):
        text += ".0"
    return text + suffix


def math_fn(name: str, dtype: np.dtype) -> str:
    """The C99 <math.h> function for `dtype`: `tanh` for double, `tanhf` for float."""
    return name + ("f" if dtype == np.float32 else "")
