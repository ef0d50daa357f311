"""Direct FMI calls for the master's inner loop: one call moves all Real inputs or outputs of an FMU.

fmpy's convenience methods build ctypes arrays from Python lists and look the function up on every call, which costs
more than the networks' own step. Here the value references, the value buffer (a numpy array the FMU reads from or
writes into) and the C function are prepared once; a step then costs one foreign call per transfer. The C functions
are bound to prototypes of our own from the FMU's shared library (loaded by fmpy), so FMI 2 and FMI 3 look the same.
"""

from __future__ import annotations

from collections.abc import Sequence
from ctypes import CFUNCTYPE, POINTER, byref, c_bool, c_double, c_int, c_size_t, c_uint32, c_void_p
from dataclasses import dataclass

import numpy as np

from nnfmu.cosim.slave import FmuSlave
from nnfmu.errors import NnfmuError

WARNING = 1  # fmi2Warning = fmi3Warning: a status above it means the call failed
STATUS_NAMES = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")
LOGGED_LINES = 3  # how many of the FMU's latest log messages an error quotes

_DOUBLES = POINTER(c_double)
_REFERENCES = POINTER(c_uint32)  # fmi2ValueReference (unsigned int) and fmi3ValueReference (uint32_t)
_TRANSFER2 = CFUNCTYPE(c_int, c_void_p, _REFERENCES, c_size_t, _DOUBLES)
_TRANSFER3 = CFUNCTYPE(c_int, c_void_p, _REFERENCES, c_size_t, _DOUBLES, c_size_t)
_SLOPES2 = CFUNCTYPE(c_int, c_void_p, _REFERENCES, c_size_t, POINTER(c_int), _DOUBLES)
_DO_STEP2 = CFUNCTYPE(c_int, c_void_p, c_double, c_double, c_int)
_DO_STEP3 = CFUNCTYPE(
    c_int, c_void_p, c_double, c_double, c_bool, POINTER(c_bool), POINTER(c_bool), POINTER(c_bool), _DOUBLES
)


class FmiStatusError(NnfmuError, RuntimeError):
    """An FMI call returned Discard, Error or Fatal; the message names the instance, the function, the status and
    what the FMU logged last."""

    def __init__(self, slave: FmuSlave, function: str, status: int) -> None:
        self.status = status
        name = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
        logged = "; ".join(message for _, _, message in slave.messages[-LOGGED_LINES:])
        super().__init__(
            f"{slave.instance_name} ({slave.path.name}): {function} returned {name}" + (f": {logged}" if logged else "")
        )


class RealBlock:
    """Real variables `names` of `slave` tied to the float64 array `values`: `set()` writes the array to the FMU's
    variables and `get()` reads them into it, each with one FMI call.

    `values` may be a contiguous view into a larger array (a row of results), so an output lands where it is kept.
    With a unit conversion (`convert`), `set()` first turns the array in place into the FMU's units and `get()`
    turns what the FMU wrote into the master's (value * scale + offset, per variable).
    """

    def __init__(self, slave: FmuSlave, names: Sequence[str], values: np.ndarray | None = None) -> None:
        n = len(names)
        self.values = np.zeros(n) if values is None else values
        if self.values.shape != (n,) or self.values.dtype != np.float64 or not self.values.flags.c_contiguous:
            raise ValueError(
                f"{slave.instance_name}: a block of {n} Real variables needs a contiguous float64 "
                f"array of {n} values, got shape {self.values.shape} {self.values.dtype}"
            )
        self.slave = slave
        self.names = list(names)
        references = (c_uint32 * n)(*slave.value_references(self.names))
        pointer = self.values.ctypes.data_as(_DOUBLES)
        library, instance = slave.fmu.dll, slave.fmu.component
        if slave.fmi_version == 2:
            self._set_name, self._get_name = "fmi2SetReal", "fmi2GetReal"
            self._set = _TRANSFER2((self._set_name, library))
            self._get = _TRANSFER2((self._get_name, library))
            self._args = (instance, references, n, pointer)
        else:
            self._set_name, self._get_name = "fmi3SetFloat64", "fmi3GetFloat64"
            self._set = _TRANSFER3((self._set_name, library))
            self._get = _TRANSFER3((self._get_name, library))
            self._args = (instance, references, n, pointer, n)
        self.references = references  # the C function reads them on every call (so does the C loop): keep them alive
        self.scale: np.ndarray | None = None
        self.offset: np.ndarray | None = None

    def convert(self, scale: np.ndarray, offset: np.ndarray) -> None:
        """Apply value * scale + offset (per variable) before each set, or after each get (None when all identity)."""
        n = len(self.names)
        if np.all(scale == 1.0) and np.all(offset == 0.0):
            self.scale = self.offset = None
            return
        self.scale = np.ascontiguousarray(scale, dtype=np.float64).reshape(n)
        self.offset = np.ascontiguousarray(offset, dtype=np.float64).reshape(n)

    def set(self) -> None:
        if self.scale is not None:
            self.values *= self.scale
            self.values += self.offset
        status = self._set(*self._args)
        if status > WARNING:
            raise self.set_error(status)

    def get(self) -> None:
        status = self._get(*self._args)
        if status > WARNING:
            raise self.get_error(status)
        if self.scale is not None:
            self.values *= self.scale
            self.values += self.offset

    def set_error(self, status: int) -> FmiStatusError:
        return FmiStatusError(self.slave, f"{self._set_name}({', '.join(self.names)})", status)

    def get_error(self, status: int) -> FmiStatusError:
        return FmiStatusError(self.slave, f"{self._get_name}({', '.join(self.names)})", status)


class SlopeBlock:
    """FMI 2 input derivatives of `names` (order 1: each input's slope over the coming step) from the float64 array
    `values`, set with one direct call of fmi2SetRealInputDerivatives."""

    def __init__(self, slave: FmuSlave, names: Sequence[str]) -> None:
        if not slave.takes_input_slopes:
            raise ValueError(f"{slave.instance_name}: the FMU cannot interpolate its inputs (canInterpolateInputs)")
        n = len(names)
        self.slave = slave
        self.names = list(names)
        self.values = np.zeros(n)
        self.references = (c_uint32 * n)(*slave.value_references(self.names))
        self.orders = (c_int * n)(*([1] * n))
        self._call = _SLOPES2(("fmi2SetRealInputDerivatives", slave.fmu.dll))
        self._args = (slave.fmu.component, self.references, n, self.orders, self.values.ctypes.data_as(_DOUBLES))
        self.scale: np.ndarray | None = None  # the inputs' unit scales: a slope converts by the scale alone

    def set(self) -> None:
        if self.scale is not None:
            self.values *= self.scale
        status = self._call(*self._args)
        if status > WARNING:
            raise self.error(status)

    def error(self, status: int) -> FmiStatusError:
        return FmiStatusError(self.slave, f"fmi2SetRealInputDerivatives({', '.join(self.names)})", status)


class Stepper:
    """`slave`'s doStep as one direct call: `step(t, h)` advances the FMU from t by h (FMI 3's event and early-return
    flags are not used by a fixed-step master and are ignored)."""

    def __init__(self, slave: FmuSlave) -> None:
        self.slave = slave
        library, instance = slave.fmu.dll, slave.fmu.component
        if slave.fmi_version == 2:
            self._name = "fmi2DoStep"
            self._do_step = _DO_STEP2((self._name, library))
            self._flags: tuple[object, ...] = (1,)  # noSetFMUStatePriorToCurrentPoint = fmi2True
        else:
            self._name = "fmi3DoStep"
            self._do_step = _DO_STEP3((self._name, library))
            self._outputs = (c_bool(), c_bool(), c_bool(), c_double())
            self._flags = (True, *(byref(flag) for flag in self._outputs))
        self._instance = instance

    def step(self, t: float, h: float) -> None:
        status = self._do_step(self._instance, t, h, *self._flags)
        if status > WARNING:
            raise self.error(t, h, status)

    def error(self, t: float, h: float, status: int) -> FmiStatusError:
        return FmiStatusError(self.slave, f"{self._name}(t = {t:.9g} s, h = {h:.9g} s)", status)


@dataclass(eq=False, slots=True)
class ElementTransfers:
    """One element's transfers in a step, prepared once: its coupling inputs gathered from the values row at
    `sources` into `coupled`, the drive's values into `driven` (the driven element only), one set of all its inputs, one
    doStep, one get of all its Real outputs into `span` of the values row. An element with `feedthrough` is set its
    inputs at t_{n+1} after the step (refresh); `slopes` (FMI 2, inputs interpolated) takes their slopes over it.
    The master's Python loop and its C loop (`inner_loop`) both step these."""

    name: str
    driven_element: bool
    feedthrough: bool
    sources: np.ndarray
    coupled: np.ndarray
    driven: np.ndarray
    inputs: RealBlock | None
    slopes: SlopeBlock | None
    outputs: RealBlock
    stepper: Stepper
    span: slice
