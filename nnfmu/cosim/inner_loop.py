"""The master's one-pass schemes stepped in C (`templates/c/inner_loop.c`): the same arithmetic as the Python loop,
without a foreign call per transfer, which is most of a step's cost when nine FMUs exchange every millisecond.

The C source ships with the templates (the system FMU of `nnfmu system build` compiles the same loop) and is
compiled once per machine with the host C compiler (the one `nnfmu build` uses) into a cache folder (`$NNFMU_CACHE`,
else `$XDG_CACHE_HOME/nnfmu`, else `~/.cache/nnfmu`), named by the hash of source, header and compiler command;
without a compiler the master keeps its Python loop. Everything the C loop touches is a numpy array or ctypes object
held by `CompiledLoop`, so the buffers stay alive and Python can read them after a failed call.
"""

from __future__ import annotations

import hashlib
import os
from ctypes import CDLL, Structure, byref, c_double, c_int, c_int64, c_void_p, cast
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nnfmu.atomic import scratch_dir
from nnfmu.cosim.direct import ElementTransfers
from nnfmu.resources import templates_dir

SOURCE = templates_dir() / "c" / "inner_loop.c"
HEADER = SOURCE.with_name("inner_loop.h")
CALL_NAMES = ("set inputs", "set input slopes", "step", "get outputs", "refresh: set inputs", "refresh: get outputs")
_LIBRARY: CDLL | None = None


class _CElement(Structure):
    """`nn_element` of inner_loop.h."""

    _fields_ = (
        [
            (name, c_void_p)
            for name in ("instance", "set_real", "get_real", "set_slopes", "do_step", "input_references", "inputs")
        ]
        + [
            ("n_coupled", c_int64),
            ("n_driven", c_int64),
            ("sources", c_void_p),
            ("slope_references", c_void_p),
            ("slope_orders", c_void_p),
            ("slopes", c_void_p),
            ("output_references", c_void_p),
            ("n_outputs", c_int64),
            ("span_start", c_int64),
            ("is_driven", c_int64),
            ("feedthrough", c_int64),
        ]
        + [(name, c_void_p) for name in ("in_scale", "in_offset", "out_scale", "out_offset")]
    )


class _CPlan(Structure):
    """`nn_plan` of inner_loop.h."""

    _fields_ = [
        ("elements", c_void_p),
        ("n_elements", c_int64),
        ("group_starts", c_void_p),
        ("n_groups", c_int64),
        ("refreshed", c_void_p),
        ("n_refreshed", c_int64),
        ("n_values", c_int64),
        ("n_drive", c_int64),
        ("linear_extrapolation", c_int64),
        ("gauss_seidel", c_int64),
    ] + [(name, c_void_p) for name in ("values", "now", "before", "estimate", "fresh")]


class _CFailure(Structure):
    """`nn_failure` of inner_loop.h."""

    _fields_ = [("step", c_int64), ("element", c_int64), ("call", c_int64), ("status", c_int64)]


@dataclass(frozen=True)
class LoopSystem:
    """What the C loop steps, as the master prepared it: the elements' transfers in `groups` (one element a group
    under Gauss-Seidel, all in one under Jacobi), those refreshed at t_{n+1} after each step, the values row their
    outputs land in, the drive's width, and the scheme (linear extrapolation or none; Gauss-Seidel or Jacobi)."""

    groups: list[list[ElementTransfers]]
    refreshed: list[ElementTransfers]
    values: np.ndarray
    drive_size: int
    linear_extrapolation: bool
    gauss_seidel: bool


@dataclass(frozen=True)
class LoopFailure:
    """A call the C loop saw fail: step index, the element, which call (`CALL_NAMES`) and the FMI status."""

    step: int
    element: ElementTransfers
    call: str
    status: int


def cache_dir() -> Path:
    """Where compiled helpers are kept: `$NNFMU_CACHE`, else `$XDG_CACHE_HOME/nnfmu`, else `~/.cache/nnfmu`."""
    if os.environ.get("NNFMU_CACHE"):
        return Path(os.environ["NNFMU_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "nnfmu"


def cached_library(source: Path, headers: tuple[Path, ...] = ()) -> Path | None:
    """The shared library of the C file `source` (including `headers`), compiled on first use with the host
    compiler into `cache_dir()` under the hash of the sources and the compiler command; None without a compiler."""
    from nnfmu.fmu import CompilerError, compile_shared_library, host_target

    try:
        target = host_target()
    except CompilerError:
        return None
    key = hashlib.sha256(
        b"".join(path.read_bytes() for path in (source, *headers))
        + "\0".join((*target.compiler, *target.flags)).encode()
    ).hexdigest()
    path = cache_dir() / f"{source.stem}-{key[:16]}{target.suffix}"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        with scratch_dir(".build-", path.parent) as scratch:
            built = Path(scratch) / path.name
            try:
                compile_shared_library(target, [source], source.parent, built)
            except CompilerError:
                return None
            os.replace(built, path)  # atomic: a concurrent master finds the whole library or none
    return path


def load_steps_library(source: Path, headers: tuple[Path, ...], function: str) -> CDLL | None:
    """`cached_library` of `source` loaded, with its stepping `function` typed: the master's loop and the compiled
    engine's share one signature (context, first step, steps, t0, h, three arrays). None without a compiler."""
    path = cached_library(source, headers)
    if path is None:
        return None
    loaded = CDLL(str(path))
    steps = getattr(loaded, function)
    steps.argtypes = [c_void_p, c_int64, c_int64, c_double, c_double, c_void_p, c_void_p, c_void_p]
    steps.restype = c_int
    return loaded


def library() -> CDLL | None:
    """The compiled loop (compiled on first use, then from the cache); None when no host C compiler can build it."""
    global _LIBRARY
    if _LIBRARY is None:
        _LIBRARY = load_steps_library(SOURCE, (HEADER,), "nn_cosim_steps")
    return _LIBRARY


def function_address(function: object) -> int:
    """The address of a ctypes function (an FMU's FMI function handed to a C loop)."""
    return cast(function, c_void_p).value


def _pointer(array: np.ndarray) -> int:
    return array.ctypes.data


class CompiledLoop:
    """The prepared C loop for `system` (every FMU FMI 2, one pass per step; `library()` not None)."""

    def __init__(self, system: LoopSystem) -> None:
        self.library = library()
        groups = system.groups
        order = [element for group in groups for element in group]
        self.order = order
        self.gauss_seidel = system.gauss_seidel
        index = {id(element): i for i, element in enumerate(order)}
        keep: list[object] = []  # arrays the C structs point into
        elements = (_CElement * len(order))()
        for slot, element in zip(elements, order):
            slave = element.outputs.slave
            dll, inputs = slave.fmu.dll, element.inputs
            sources = np.ascontiguousarray(element.sources, dtype=np.int64)
            keep.append(sources)
            slot.instance = slave.fmu.component
            slot.set_real, slot.get_real = function_address(dll.fmi2SetReal), function_address(dll.fmi2GetReal)
            slot.do_step = function_address(dll.fmi2DoStep)
            slot.n_coupled, slot.n_driven = len(element.sources), len(element.driven)
            slot.sources = _pointer(sources)
            if inputs is not None:
                slot.input_references, slot.inputs = cast(inputs.references, c_void_p).value, _pointer(inputs.values)
            if element.slopes is not None:
                slopes = element.slopes
                slot.set_slopes = function_address(dll.fmi2SetRealInputDerivatives)
                slot.slope_references = cast(slopes.references, c_void_p).value
                slot.slope_orders = cast(slopes.orders, c_void_p).value
                slot.slopes = _pointer(slopes.values)
            slot.output_references = cast(element.outputs.references, c_void_p).value
            slot.n_outputs, slot.span_start = len(element.outputs.names), element.span.start
            slot.is_driven, slot.feedthrough = int(element.driven_element), int(element.feedthrough)
            if inputs is not None and inputs.scale is not None:
                slot.in_scale, slot.in_offset = _pointer(inputs.scale), _pointer(inputs.offset)
            if element.outputs.scale is not None:
                slot.out_scale, slot.out_offset = _pointer(element.outputs.scale), _pointer(element.outputs.offset)
        starts = np.cumsum([0] + [len(group) for group in groups], dtype=np.int64)
        refreshed = np.array([index[id(e)] for e in system.refreshed], dtype=np.int64)
        self.values, n = system.values, len(system.values)
        self.now, self.before = np.zeros(n), np.zeros(n)
        self.estimate, self.fresh = np.zeros(n), np.zeros(n)
        keep += [starts, refreshed]
        self.plan = _CPlan(
            elements=cast(elements, c_void_p).value,
            n_elements=len(order),
            group_starts=_pointer(starts),
            n_groups=len(groups),
            refreshed=_pointer(refreshed),
            n_refreshed=len(refreshed),
            n_values=n,
            n_drive=system.drive_size,
            linear_extrapolation=int(system.linear_extrapolation),
            gauss_seidel=int(system.gauss_seidel),
            values=_pointer(self.values),
            now=_pointer(self.now),
            before=_pointer(self.before),
            estimate=_pointer(self.estimate),
            fresh=_pointer(self.fresh),
        )
        self._keep = (keep, elements)
        self.failure = _CFailure()

    def start(self, now: np.ndarray, before: np.ndarray) -> None:
        """Take the coupling values at t0 (`now`) and before it from the initialised system."""
        self.now[:] = now
        self.before[:] = before

    def steps(
        self, first: int, last: int, t0: float, h: float, drive: np.ndarray, rows: np.ndarray
    ) -> LoopFailure | None:
        """Steps first .. last - 1 with `drive` at t_first .. t_last (C-contiguous float64), each step's values row
        into `rows` (last - first rows); the failing call, or None."""
        drive = np.ascontiguousarray(drive, dtype=np.float64)
        if rows.shape != (last - first, len(self.values)) or not rows.flags.c_contiguous or rows.dtype != np.float64:
            raise ValueError(
                f"rows for steps {first}..{last} must be a C-contiguous float64 array of shape "
                f"({last - first}, {len(self.values)}), got {rows.shape} {rows.dtype}"
            )
        if (
            self.library.nn_cosim_steps(
                byref(self.plan), first, last, t0, h, _pointer(drive), _pointer(rows), byref(self.failure)
            )
            == 0
        ):
            return None
        failure = self.failure
        return LoopFailure(failure.step, self.order[failure.element], CALL_NAMES[failure.call], failure.status)

    @property
    def source(self) -> np.ndarray:
        """The coupling values the elements were set from in the latest step (the estimate, with fresh outputs
        under Gauss-Seidel)."""
        return self.fresh if self.gauss_seidel else self.estimate
