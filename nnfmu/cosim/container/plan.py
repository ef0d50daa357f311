"""What a system FMU holds, planned by the master itself: the parts in stepping order with their value references,
the values row, the unit conversions, the refresh and the initial wiring, taken from a `_System` the Python master
builds for the same system and settings, so the C master steps exactly what `cosimulate` would."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from nnfmu.cosim.binding import DriveBinding, bind_free_inputs
from nnfmu.cosim.master import CosimError, CosimSettings, _System
from nnfmu.cosim.ssp import SystemStructure
from nnfmu.cosim.units import port_unit
from nnfmu.data import Measurement

if TYPE_CHECKING:
    from nnfmu.fmu import Platform

FOLDER = "fmus"  # under the system FMU's resources/: fmus/<index of the first part it serves>/ per distinct FMU


@dataclass(frozen=True)
class Part:
    """One inner FMU as the C master sees it (inner_loop.h's `nn_element`, plus what loading it takes)."""

    name: str
    folder: str  # relative to the system FMU's resources/
    identifier: str
    guid: str  # FMI 3: the instantiation token
    fmi_version: int
    input_references: tuple[int, ...]  # coupled inputs, then the drive's (the driven part)
    n_coupled: int
    sources: tuple[int, ...]
    in_scale: tuple[float, ...] | None
    in_offset: tuple[float, ...] | None
    output_references: tuple[int, ...]
    out_scale: tuple[float, ...] | None
    out_offset: tuple[float, ...] | None
    span_start: int
    is_driven: bool
    feedthrough: bool
    takes_slopes: bool


@dataclass(frozen=True)
class Link:
    """A connection for initialisation: part `source`'s output reference -> part `target`'s input reference; the
    value passed is a * (s * output + o) + b (`_System._link_conversion`)."""

    source: int
    output: int
    s: float
    o: float
    target: int
    input: int
    a: float
    b: float


@dataclass(frozen=True)
class Variable:
    """A variable of the system FMU: name, unit ('' for none), description, and for a parameter its part, the part's
    value reference, its start value and whether the SSD sets it."""

    name: str
    unit: str
    description: str
    part: int = -1
    reference: int = 0
    start: float = 0.0
    bound: bool = False


@dataclass(frozen=True)
class SystemPlan:
    """Everything the C master and the model description need."""

    name: str
    parts: tuple[Part, ...]
    group_starts: tuple[int, ...]
    refreshed: tuple[int, ...]
    links: tuple[Link, ...]
    inputs: tuple[Variable, ...]  # the drive: the driven part's free inputs
    outputs: tuple[Variable, ...]  # the values row, as `cosimulate` names its channels
    parameters: tuple[Variable, ...]
    inner_step: float
    settings: CosimSettings
    start_time: float
    stop_time: float | None
    extrapolate_drive: bool  # without input derivatives: the drive extrapolated from the step before (else held)
    states: bool  # every part can get and set its FMU state: so can the system FMU
    serializes: bool  # every part can also serialise it


def _drive_units(system: SystemStructure, binding: DriveBinding) -> dict[str, str]:
    """Each drive channel's unit: the SI unit of the input it feeds where known, else its declared unit."""
    from fmpy import read_model_description

    description = read_model_description(str(system.fmu_path(binding.element)))
    variables = {v.name: v for v in description.modelVariables}
    units = {}
    for name, channel in zip(binding.inputs, binding.channels):
        if name not in variables:
            raise CosimError(f"system {system.name!r}: element {binding.element!r} has no input {name!r}")
        units[channel] = port_unit(variables[name], description.unitDefinitions or ()).row_unit
    return units


def plan_system(
    system: SystemStructure,
    settings: CosimSettings,
    inner_step: float,
    binding: DriveBinding | None = None,
    copy_to: Path | None = None,
    extrapolate_drive: bool = True,
    platforms: tuple[Platform, ...] | None = None,
) -> SystemPlan:
    """The plan of `system` under `settings` (one pass per step: iterations 0, extrapolation 'linear'; no port
    derivatives) at the fixed inner step `inner_step` [s]; with `copy_to`, each distinct FMU is copied unpacked to
    copy_to/fmus/<index>/ on the way with the binaries of `platforms` it has (None: the host's; parts of one FMU share
    its folder and library, unless it may be instantiated only once per process). `extrapolate_drive`: a step the outer
    master sets no input derivatives for takes the drive's slope from the step before (else holds it). CosimError
    naming what cannot be built."""
    if settings.iterations or settings.plain:
        raise CosimError(
            "a system FMU steps nnfmu's one-pass schemes only (iterations 0, extrapolation 'linear'); "
            f"got iterations {settings.iterations}, extrapolation {settings.extrapolation!r}"
        )
    binding = binding if binding is not None else bind_free_inputs(system)
    units = _drive_units(system, binding)
    drive = Measurement.uniform(
        0.0, 1.0, {c: np.zeros(2) for c in binding.channels}, units, source=f"the inputs of system {system.name!r}"
    )
    parts = _System(system, drive, settings, binding=binding)
    try:
        parts.check_periods(system.name, inner_step)
        if parts.derivatives is not None and parts.derivatives.active:
            raise CosimError(
                f"system {system.name!r}: element inputs set from port derivatives "
                f"({', '.join(parts.derivatives.names())}); "
                "a system FMU leaves them at their start values: plan it with port_derivatives=False (the python "
                "engine of `nnfmu cosim` sets them)"
            )
        return _plan(system, parts, settings, inner_step, binding, units, copy_to, extrapolate_drive, platforms)
    finally:
        parts.close(healthy=False)


def _copy_part(source: Path, target: Path, platform_folders: tuple[str, ...]) -> None:
    """An unpacked FMU into `target`, with only the binaries of `platform_folders` it has (`build_system_fmu` names
    the platforms a part lacks)."""
    shutil.copytree(
        source,
        target,
        ignore=lambda folder, names: [
            n for n in names if Path(folder) == source / "binaries" and n not in platform_folders
        ],
    )


def _plan(
    system: SystemStructure,
    parts: _System,
    settings: CosimSettings,
    inner_step: float,
    binding: DriveBinding,
    units: dict[str, str],
    copy_to: Path | None,
    extrapolate_drive: bool,
    platforms: tuple[Platform, ...] | None,
) -> SystemPlan:
    """The plan from the master's prepared `parts` (see `plan_system`)."""
    from nnfmu.fmu import host_platform_of

    carried = platforms if platforms is not None else (host_platform_of(),)
    order = [element for group in parts.groups for element in group]
    index = {id(element): i for i, element in enumerate(order)}
    position = {e.name: i for i, e in enumerate(order)}
    built = []
    copied: dict[str, str] = {}  # an FMU's digest (`FmuSlave.shared_as`) -> the folder it was copied to
    for i, element in enumerate(order):
        slave = element.outputs.slave
        key = slave.shared_as  # the parts the master shares a folder between share one in the system FMU
        folder = copied.get(key) if key is not None else None
        if folder is None:
            folder = f"{FOLDER}/{i}"
            if copy_to is not None:
                folders = tuple(p.folder(slave.fmi_version) for p in carried)
                _copy_part(Path(slave.directory), copy_to / folder, folders)
            if key is not None:
                copied[key] = folder
        inputs = element.inputs
        conversions = inputs is not None and inputs.scale is not None
        outputs = element.outputs
        built.append(
            Part(
                name=element.name,
                folder=folder,
                identifier=slave.description.coSimulation.modelIdentifier,
                guid=slave.description.guid if slave.fmi_version == 2 else slave.description.instantiationToken,
                fmi_version=slave.fmi_version,
                input_references=tuple(slave.value_references(inputs.names)) if inputs is not None else (),
                n_coupled=len(element.sources),
                sources=tuple(int(s) for s in element.sources),
                in_scale=tuple(map(float, inputs.scale)) if conversions else None,
                in_offset=tuple(map(float, inputs.offset)) if conversions else None,
                output_references=tuple(slave.value_references(outputs.names)),
                out_scale=tuple(map(float, outputs.scale)) if outputs.scale is not None else None,
                out_offset=tuple(map(float, outputs.offset)) if outputs.scale is not None else None,
                span_start=element.span.start,
                is_driven=element.driven_element,
                feedthrough=element.feedthrough,
                takes_slopes=element.slopes is not None,
            )
        )
    links = tuple(
        Link(
            position[link.source],
            parts.slaves[link.source].value_references([link.output])[0],
            s,
            o,
            position[link.target],
            parts.slaves[link.target].value_references([link.input])[0],
            a,
            b,
        )
        for link, (s, o, a, b) in zip(parts.links, parts.link_conversions)
    )
    inputs = tuple(
        Variable(channel, units[channel], f"drive: input {name} of element {binding.element}")
        for name, channel in zip(binding.inputs, binding.channels)
    )
    owners = [(name, output) for name, outs in parts.outputs.items() for output in outs]
    outputs = tuple(
        Variable(channel, unit, f"output {output} of element {name}")
        for (channel, unit), (name, output) in zip(parts.channels(), owners)
    )
    parameters = []
    for i, element in enumerate(order):
        slave = element.outputs.slave
        values = parts.parameters[element.name]
        for variable in slave.description.modelVariables:
            if variable.causality != "parameter" or variable.type not in ("Real", "Float64"):
                continue
            bound = variable.name in values
            start = float(values[variable.name]) if bound else float(variable.start or 0.0)
            parameters.append(
                Variable(
                    f"{element.name}.{variable.name}",
                    slave.port_unit(variable.name).text,
                    f"parameter {variable.name} of element {element.name}",
                    part=i,
                    reference=variable.valueReference,
                    start=start,
                    bound=bound,
                )
            )
    names = [v.name for v in (*inputs, *outputs, *parameters)]
    clashes = sorted({n for n in names if names.count(n) > 1})
    if clashes:
        raise CosimError(
            f"system {system.name!r}: the system FMU would have two variables named {', '.join(clashes)} (an input, "
            "an output or an element.parameter); rename an element or port"
        )
    starts = np.cumsum([0] + [len(group) for group in parts.groups])
    return SystemPlan(
        name=system.name,
        parts=tuple(built),
        group_starts=tuple(int(s) for s in starts),
        refreshed=tuple(index[id(e)] for e in parts.refreshed),
        links=links,
        inputs=inputs,
        outputs=outputs,
        parameters=tuple(parameters),
        inner_step=inner_step,
        settings=settings,
        start_time=system.start_time,
        stop_time=system.stop_time,
        extrapolate_drive=extrapolate_drive,
        states=all(bool(e.outputs.slave.description.coSimulation.canGetAndSetFMUstate) for e in order),
        serializes=all(bool(e.outputs.slave.description.coSimulation.canSerializeFMUstate) for e in order),
    )
