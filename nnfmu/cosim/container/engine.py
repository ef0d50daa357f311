"""`nnfmu cosim --engine compiled`: an SSP system run as its system FMU (`nnfmu system build`, inner step = the
communication step; built once and cached, `cache.py`), opened by fmpy and stepped from C (`templates/c/system_loop.c`:
per step the drive at t_n, its slopes toward t_{n+1}, doStep, every output), so nothing per step passes through
Python. The system FMU's master is the Python master's one-pass loop planned from the same wiring, so the result is
`cosimulate`'s (same channels, units and time axis; tested to 1e-12 on the quarter car)."""

from __future__ import annotations

import time as clock
from ctypes import CDLL, Structure, byref, c_int64, c_void_p

import numpy as np

from nnfmu.cosim.binding import DriveBinding, bind_free_inputs
from nnfmu.cosim.container.cache import cached_system_fmu
from nnfmu.cosim.drive_inputs import DriveInputs
from nnfmu.cosim.inner_loop import function_address, load_steps_library
from nnfmu.cosim.instances import InstancePool
from nnfmu.cosim.master import (
    DRIVE_BLOCK,
    Progress,
    _check_channel_units,
    result_table,
    result_unit,
    step_count,
    whole_steps,
)
from nnfmu.cosim.results import CosimResult
from nnfmu.cosim.settings import CosimError, CosimSettings
from nnfmu.cosim.slave import FmuSlave
from nnfmu.cosim.ssp import SystemStructure
from nnfmu.cosim.units import input_conversion, table_unit
from nnfmu.data import Measurement
from nnfmu.resources import templates_dir
from nnfmu.stopping import check_stop

SOURCE = templates_dir() / "c" / "system_loop.c"
CALLS = ("set inputs", "set input slopes", "doStep", "get outputs")
INSTANCE = "system"
_LIBRARY: CDLL | None = None


class _Driver(Structure):
    """`ns_driver` of system_loop.c."""

    _fields_ = [(name, c_void_p) for name in ("instance", "set_real", "get_real", "set_slopes", "do_step")] + [
        ("input_references", c_void_p),
        ("n_inputs", c_int64),
        ("orders", c_void_p),
        ("output_references", c_void_p),
        ("n_outputs", c_int64),
        ("slopes", c_void_p),
    ]


class _Failure(Structure):
    """`ns_failure` of system_loop.c."""

    _fields_ = [("step", c_int64), ("call", c_int64), ("status", c_int64)]


def check_compiled(settings: CosimSettings) -> None:
    """CosimError naming the settings the compiled engine cannot run (its system FMU steps one-pass schemes)."""
    if settings.iterations or settings.extrapolation != "linear":
        raise CosimError(
            "the compiled engine steps nnfmu's one-pass schemes only (iterations 0, extrapolation linear); got "
            f"iterations {settings.iterations}, extrapolation {settings.extrapolation!r}: use the python engine"
        )
    if settings.inner_loop == "python":
        raise CosimError("inner_loop 'python' asks for the Python loop: the compiled engine steps in C only")


def _library() -> CDLL:
    """system_loop.c compiled (once per machine, cached); CosimError without a host C compiler."""
    global _LIBRARY
    if _LIBRARY is None:
        _LIBRARY = load_steps_library(SOURCE, (), "ns_drive_steps")
        if _LIBRARY is None:
            raise CosimError("the compiled engine needs a host C compiler (set CC or install gcc/clang)")
    return _LIBRARY


def _logged(slave: FmuSlave) -> str:
    """What the system FMU logged as errors (its parts' messages come named), for an error message."""
    lines = [message for status, _, message in slave.messages if status >= 2]
    return f": {'; '.join(lines[-4:])}" if lines else ""


def cosimulate_compiled(
    system: SystemStructure,
    drive: Measurement,
    settings: CosimSettings,
    progress: Progress | None = None,
    pool: InstancePool | None = None,
    binding: DriveBinding | None = None,
) -> CosimResult:
    """Run `system` driven by `drive` as its system FMU stepped from C at settings.step; the `cosimulate` result
    (every output at t_n = t0 + n h, same channel names and units). CosimError for settings it cannot run
    (`check_compiled`), a system it cannot build into one FMU, or a failing call (naming the element inside)."""
    check_compiled(settings)
    binding = binding if binding is not None else bind_free_inputs(system)
    path, built = cached_system_fmu(system, settings, binding)
    library = _library()
    slave = pool.take(path, INSTANCE, True) if pool is not None else FmuSlave(path, INSTANCE, unpacked=True)
    healthy = False
    try:
        inputs, outputs = slave.names("input"), slave.names("output")
        source = DriveInputs(drive, inputs)
        conversions = [
            input_conversion(
                table_unit(unit, name),
                slave.port_unit(name),
                f"system {system.name!r}: drive channel {name!r} of {source.source} into the system FMU",
                "the drive",
            )
            for name, unit in zip(inputs, source.units)
        ]
        scale = np.array([a for a, _ in conversions])
        offset = np.array([b for _, b in conversions])
        h, t0 = settings.step, settings.start_time
        stop = settings.stop_time if settings.stop_time is not None else system.stop_time
        n_steps = step_count(t0, stop, h) if stop is not None else whole_steps(t0, source.end, h)
        source.at(t0 + n_steps * h)  # a drive that ends early fails here, before the run
        channels = [(name, result_unit(slave.port_unit(name), name)) for name in outputs]
        _check_channel_units(system.name, channels)
        rows = result_table(n_steps, len(channels))
        in_refs = np.array(slave.value_references(inputs), dtype=np.uint32)
        out_refs = np.array(slave.value_references(outputs), dtype=np.uint32)
        orders = np.ones(len(inputs), dtype=np.intc)
        slopes = np.zeros(len(inputs))
        dll = slave.fmu.dll
        driver = _Driver(
            instance=slave.fmu.component,
            set_real=function_address(dll.fmi2SetReal),
            get_real=function_address(dll.fmi2GetReal),
            set_slopes=function_address(dll.fmi2SetRealInputDerivatives),
            do_step=function_address(dll.fmi2DoStep),
            input_references=in_refs.ctypes.data,
            n_inputs=len(inputs),
            orders=orders.ctypes.data,
            output_references=out_refs.ctypes.data,
            n_outputs=len(outputs),
            slopes=slopes.ctypes.data,
        )
        try:
            slave.enter_initialization(t0)
            if inputs:
                slave.set_real(inputs, source.at(t0) * scale + offset)
            slave.exit_initialization()
            rows[0] = slave.get_real(outputs)
        except Exception as error:  # fmpy's FMICallException: the status; the reason is in the log
            raise CosimError(
                f"system {system.name!r} (compiled engine), initialisation: {error}{_logged(slave)}"
            ) from None
        failure = _Failure()
        every = max(1, n_steps // 200)
        started = clock.perf_counter()
        for first in range(0, n_steps, DRIVE_BLOCK):
            last = min(first + DRIVE_BLOCK, n_steps)
            block = np.ascontiguousarray(source.table(t0 + np.arange(first, last + 1) * h) * scale + offset)
            for start in range(first, last, every):
                check_stop()  # between calls of the C loop, which no signal interrupts
                end = min(start + every, last)
                status = library.ns_drive_steps(
                    byref(driver),
                    start,
                    end,
                    t0,
                    h,
                    block[start - first :].ctypes.data,
                    rows[start + 1 : end + 1].ctypes.data,
                    byref(failure),
                )
                if status:
                    t = t0 + failure.step * h
                    raise CosimError(
                        f"system {system.name!r} (compiled engine), step from t = {t:.9g} s: "
                        f"{CALLS[failure.call]} failed with status {failure.status}{_logged(slave)}"
                    )
                if progress is not None:
                    progress(end, n_steps)
        elapsed = clock.perf_counter() - started
        healthy = True
    finally:
        if pool is not None:
            pool.give(slave, healthy)
        else:
            slave.close()
    measurement = Measurement.uniform(
        t0,
        h,
        channels={name: rows[:, i] for i, (name, _) in enumerate(channels)},
        units=dict(channels),
        source=f"co-simulation of {system.name} ({settings.scheme}, h = {h:g} s, system FMU) on {drive.source}",
        notes={"wall_time_s": f"{elapsed:.3f}", "engine": "compiled", "system_fmu": path.name, "built": str(built)},
    )
    return CosimResult(measurement, n_steps, n_steps, 0, master="compiled")
