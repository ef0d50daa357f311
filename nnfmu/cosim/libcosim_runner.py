"""Run the same SSP system in libcosim (libcosimpy), a second, independent master, to cross-check fmpy's results.

libcosim's fixed-step algorithm steps every FMU from t_n on the values transferred after the previous step, so it is
a Jacobi scheme without extrapolation, iteration or refresh; the fmpy master with `scheme="jacobi"`, the plain
settings and `refresh=False` is the same scheme, and only that combination is accepted here. libcosim counts time
in integer nanoseconds, so the step must be a whole number of nanoseconds; it logs every call at its default level,
so its output level is set to errors only. The drive inputs are set through an override manipulator before each
step, as the fmpy master sets them, and the outputs are read from a last-value observer after each step (row n + 1
belongs to t_{n+1}); row 0 is the time-series observer's record of the initialised system.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from nnfmu.cosim.binding import DriveBinding, bind_free_inputs
from nnfmu.cosim.drive_inputs import DriveInputs
from nnfmu.cosim.master import CosimError, CosimSettings, result_table, result_unit, step_count, whole_steps
from nnfmu.cosim.results import CosimResult
from nnfmu.cosim.ssp import SystemStructure, open_system
from nnfmu.cosim.units import PortUnit, input_conversion, port_unit, table_unit
from nnfmu.data import Measurement

NANOSECONDS = 1_000_000_000
UNCONVERTED = 1e-12  # relative: a connection whose unit conversion is 1 within rounding needs none
NANOSECOND_TOLERANCE = 1e-3  # [ns]: how far from a whole number of nanoseconds a time may lie (float rounding)


def _nanoseconds(seconds: float, what: str) -> int:
    ns = round(seconds * NANOSECONDS)
    if ns < 1 or abs(ns - seconds * NANOSECONDS) > NANOSECOND_TOLERANCE:
        raise CosimError(f"libcosim counts time in whole nanoseconds; the {what} {seconds!r} s is not one")
    return ns


def _check_settings(settings: CosimSettings) -> None:
    if settings.scheme != "jacobi" or not settings.plain or settings.refresh:
        raise CosimError(
            "libcosim's fixed-step algorithm is Jacobi without extrapolation, iteration or refresh; got "
            f"scheme {settings.scheme!r}, extrapolation {settings.extrapolation!r}, "
            f"iterations {settings.iterations}, refresh {settings.refresh}"
        )
    if settings.start_time != 0.0:
        raise CosimError(f"libcosim's SSP executions start at t = 0, not {settings.start_time!r} s")


def run_libcosim(
    ssd_path: str | os.PathLike[str],
    drive: Measurement,
    settings: CosimSettings,
    binding: DriveBinding | None = None,
    allow_outside: bool = False,
) -> CosimResult:
    """Co-simulate the system of `ssd_path` (.ssd, its folder or .ssp) in libcosim, the drive fed as `binding` says
    (None: `bind_free_inputs`); channels named as fmpy names them. The system's FMUs may lie outside its folder only
    if `allow_outside`."""
    from libcosimpy.CosimEnums import CosimVariableCausality, CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver

    _check_settings(settings)
    path = Path(ssd_path)
    with open_system(path, allow_outside) as system:
        h_ns = _nanoseconds(settings.step, "communication step")
        stop = settings.stop_time if settings.stop_time is not None else system.stop_time
        binding = binding if binding is not None else bind_free_inputs(system)
        driven = binding.element
        units = check_for_libcosim(system)
        log_output_level(CosimLogLevel.ERROR)
        # the system file open_system read and checked: for an .ssp the extracted copy, never the archive itself,
        # which libcosim would extract again without open_system's checks
        execution = CosimExecution.from_ssp_file(str(system.path), step_size=h_ns)
        if execution.num_slaves() != len(system.elements):
            raise CosimError(f"{path}: libcosim could not load the system")
        index = {e.name: execution.slave_index_from_instance_name(e.name) for e in system.elements}
        refs = {
            name: {v.name.decode(): (v.reference, v.causality) for v in execution.slave_variables(i)}
            for name, i in index.items()
        }
        connected = {(c.end_element, c.end_connector) for c in system.connections}
        wrong = [
            n
            for n in binding.inputs
            if refs[driven].get(n, (0, None))[1] != CosimVariableCausality.INPUT.value or (driven, n) in connected
        ]
        if wrong:
            raise CosimError(
                f"{path}: element {driven!r}: bound input(s) {', '.join(wrong)} are not free inputs of "
                "its FMU (no such input, or connected)"
            )
        drive_names = list(binding.inputs)
        inputs = DriveInputs(drive, binding.channels)
        drive_scale, drive_offset = _drive_conversion(system, inputs, binding, units)
        h = settings.step
        n_steps = step_count(0.0, stop, h) if stop is not None else whole_steps(0.0, inputs.end, h)
        channels = _channels(system, driven)
        rows = result_table(n_steps, len(channels))  # refuses a result too large before libcosim buffers it too
        drive_refs = [refs[driven][n][0] for n in drive_names]
        manipulator = CosimManipulator.create_override()
        last = CosimObserver.create_last_value()
        series = CosimObserver.create_time_series(buffer_size=n_steps + 1)  # keeps step 0
        execution.add_manipulator(manipulator)
        execution.add_observer(last)
        execution.add_observer(series)
        for element, output, _, _ in channels:
            series.start_time_series(index[element], refs[element][output][0], CosimVariableType.REAL)
        for ref, value in zip(drive_refs, drive_scale * inputs.at(0.0) + drive_offset):
            execution.real_initial_value(index[driven], ref, float(value))
        for n in range(n_steps):
            if drive_refs:
                values = drive_scale * inputs.at(n * h) + drive_offset
                manipulator.slave_real_values(index[driven], drive_refs, [float(x) for x in values])
            if not execution.step(1):
                raise CosimError(f"{path}: libcosim failed at step {n} (t = {n * h_ns} ns)")
            rows[n + 1] = _read(last, index, refs, channels)
        for j, (element, output, _, _) in enumerate(channels):
            _, steps, values = series.time_series_real_samples(index[element], refs[element][output][0], 0, 2)
            if not steps or steps[0] != 0:
                raise CosimError(f"{path}: libcosim recorded no initial value of {element}.{output}")
            rows[0, j] = values[0]
        del execution
    for j, (element, output, _, _) in enumerate(channels):  # outputs in SI where their unit converts, as fmpy's
        unit = units[element][output]
        rows[:, j] = rows[:, j] * unit.scale + unit.offset
    measurement = Measurement.uniform(
        0.0,
        h,
        channels={name: rows[:, j] for j, (_, _, name, _) in enumerate(channels)},
        units={name: result_unit(units[element][output], name) for element, output, name, _ in channels},
        source=f"libcosim co-simulation of {system.name} (h = {h_ns} ns) on {drive.source}",
    )
    return CosimResult(measurement, n_steps, n_steps, 0, master="libcosim")


def check_for_libcosim(system: SystemStructure) -> dict[str, dict[str, PortUnit]]:
    """Refuse, before libcosim loads anything, what it cannot run: an FMI 3 FMU (libcosim has no FMI 3 and loses the
    process in add_local_slave) and a connection whose ends need a unit conversion (libcosim passes values as they
    are); CosimError naming the element or connection. Returns every element's Real variables' units by name."""
    from fmpy import read_model_description

    units: dict[str, dict[str, PortUnit]] = {}
    for element in system.elements:
        fmu = system.fmu_path(element)
        description = read_model_description(str(fmu))
        if not description.fmiVersion.startswith("2"):
            raise CosimError(
                f"system {system.name!r}: element {element.name!r} ({fmu.name}) is an FMI {description.fmiVersion} "
                "FMU; libcosim runs FMI 2 co-simulation FMUs only (an FMI 3 FMU crashes it); build it with --fmi 2 "
                "or use --master fmpy"
            )
        definitions = description.unitDefinitions or ()
        units[element.name] = {
            v.name: port_unit(v, definitions) for v in description.modelVariables if v.type in ("Real", "Float64")
        }
    for c in system.connections:
        source, target = units[c.start_element][c.start_connector], units[c.end_element][c.end_connector]
        a, b = input_conversion(source, target, f"system {system.name!r}: connection {c}")
        scale, offset = a * source.scale, a * source.offset + b  # output -> input, unit to unit
        if abs(scale - 1.0) > UNCONVERTED or abs(offset) > UNCONVERTED * max(1.0, abs(b)):
            raise CosimError(
                f"system {system.name!r}: connection {c} joins {source.describe()} and {target.describe()}; "
                "libcosim passes values unconverted, so use --master fmpy (which converts) or FMUs of one unit"
            )
    return units


def _drive_conversion(
    system: SystemStructure, drive: DriveInputs, binding: DriveBinding, units: dict[str, dict[str, PortUnit]]
) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) per bound input: the value set = a * drive value (SI) + b; UnitError naming input and channel."""
    pairs = [
        input_conversion(
            table_unit(unit, channel),
            units[binding.element][name],
            f"system {system.name!r}: element {binding.element!r}, input {name!r} read from drive channel "
            f"{channel!r} of {drive.source}",
            "the drive",
        )
        for name, channel, unit in zip(binding.inputs, binding.channels, drive.units)
    ]
    return np.array([a for a, _ in pairs]), np.array([b for _, b in pairs])


def _channels(system: SystemStructure, driven: str) -> list[tuple[str, str, str, str]]:
    """(element, output, channel, unit) of every Real output, in the fmpy master's order and naming."""
    from fmpy import read_model_description

    result = []
    for element in system.elements:
        for v in read_model_description(str(system.fmu_path(element))).modelVariables:
            if v.causality == "output" and v.type in ("Real", "Float64"):
                channel = v.name if element.name == driven else f"{element.name}_{v.name}"
                unit = v.unit or (v.declaredType.unit if v.declaredType else "") or "1"
                result.append((element.name, v.name, channel, unit))
    return result


def _read(last, index: dict[str, int], refs: dict, channels: list[tuple[str, str, str, str]]) -> np.ndarray:
    values = []
    for element in index:
        wanted = [refs[element][output][0] for owner, output, _, _ in channels if owner == element]
        if wanted:
            values.extend(last.last_real_values(index[element], wanted))
    return np.array(values)
