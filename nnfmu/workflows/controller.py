"""`nnfmu controller build`, and the closed loop of a semi-active quarter car: vehicle, damper and controller FMUs
wired as one SSP system.

The closed loop (`closed_loop_system`): the quarter car's `damper_velocity` output feeds both the damper's `velocity`
input and the controller's `damper_velocity` input, its `body_velocity` the controller's; the controller's command
(`voltage` or `current`) feeds the damper's input of that name; the damper's `force` feeds the vehicle's
`damper_force`. `connect_by_name` joins components to the vehicle only, so the controller-to-damper link is why the
connections are written here: every damper input `X` reads the vehicle's `damper_X` output when it has one (velocity,
displacement), else the controller's output `X`. The vehicle's actuator inputs stay free for the drive.
"""

from __future__ import annotations

import os
from pathlib import Path

import onnx

from nnfmu.control import Command, SkyhookSettings, fixed_command_graph, known_command, skyhook_graph
from nnfmu.cosim import Connection, Connector, Element, SspError, SystemStructure, local_fmu, write_ssd
from nnfmu.errors import SettingsError
from nnfmu.fmu import BuildOptions, FmiVersion, build_fmu_from_model

__all__ = [
    "CONTROLLERS",
    "Command",
    "SkyhookSettings",
    "build_controller_fmu",
    "build_fixed_command_fmu",
    "build_graph_fmu",
    "build_skyhook_fmu",
    "closed_loop_system",
    "known_command",
    "write_closed_loop",
]

CONTROLLERS = ("skyhook",)  # the control laws `nnfmu controller build` knows
VEHICLE, DAMPER, CONTROLLER = "vehicle", "damper", "controller"
DAMPER_PORT = "damper"  # the quarter car's damper port prefix: damper_force in, damper_velocity / _displacement out


def build_graph_fmu(graph: onnx.ModelProto, out: str | os.PathLike[str], fmi_version: FmiVersion = 2) -> Path:
    """Build the native FMU of an in-memory step graph at `out`; the FMU takes the component's name."""
    return build_fmu_from_model(graph, BuildOptions(out=Path(out), fmi_version=fmi_version))


def build_skyhook_fmu(settings: SkyhookSettings, out: str | os.PathLike[str], fmi_version: FmiVersion = 2) -> Path:
    """The skyhook controller of `settings` as a native FMU at `out`; return its path."""
    return build_graph_fmu(skyhook_graph(settings), out, fmi_version)


def build_controller_fmu(
    law: str, settings: SkyhookSettings, out: str | os.PathLike[str], fmi_version: FmiVersion = 2
) -> Path:
    """`nnfmu controller build LAW`: the controller `law` (one of CONTROLLERS) as a native FMU at `out`;
    SettingsError naming an unknown law."""
    if law not in CONTROLLERS:
        raise SettingsError(f"unknown controller {law!r}; use {' or '.join(CONTROLLERS)}")
    return build_skyhook_fmu(settings, out, fmi_version)


def build_fixed_command_fmu(
    command: Command, value: float, out: str | os.PathLike[str], fmi_version: FmiVersion = 2
) -> Path:
    """A controller FMU with the skyhook controller's ports holding `command` at `value` (the passive baseline)."""
    return build_graph_fmu(fixed_command_graph(command, value), out, fmi_version)


def _real_ports(path: Path) -> dict[str, str]:
    """The FMU's Real inputs and outputs: name -> causality."""
    from fmpy import read_model_description

    return {
        v.name: v.causality
        for v in read_model_description(str(path)).modelVariables
        if v.type in ("Real", "Float64") and v.causality in ("input", "output")
    }


def closed_loop_system(
    vehicle_fmu: Path, damper_fmu: Path, controller_fmu: Path, base: Path, name: str = "semi-active quarter car"
) -> SystemStructure:
    """The closed loop of the module docstring; FMU sources relative to `base`, FMUs from outside it linked into
    `base/fmu/` (`local_fmu`: a system loads FMUs only from inside its folder). SspError naming the element and
    connector when a port finds no partner (a damper without the controller's command input, a vehicle without
    `body_velocity`, ...)."""
    given = {VEHICLE: Path(vehicle_fmu), DAMPER: Path(damper_fmu), CONTROLLER: Path(controller_fmu)}
    paths = {element: local_fmu(path, base) for element, path in given.items()}
    ports = {element: _real_ports(path) for element, path in paths.items()}
    vehicle_out = {p for p, c in ports[VEHICLE].items() if c == "output"}
    controller_out = {p for p, c in ports[CONTROLLER].items() if c == "output"}

    def missing(element: str, port: str, wanted: str) -> SspError:
        return SspError(
            f"system {name!r}: element {element!r} ({paths[element].name}), connector {port!r}: no "
            f"{wanted} to connect it to"
        )

    connections = []
    for port, causality in ports[DAMPER].items():
        if causality == "input":
            if f"{DAMPER_PORT}_{port}" in vehicle_out:
                connections.append(Connection(VEHICLE, f"{DAMPER_PORT}_{port}", DAMPER, port))
            elif port in controller_out:
                connections.append(Connection(CONTROLLER, port, DAMPER, port))
            else:
                raise missing(DAMPER, port, f"vehicle output {DAMPER_PORT}_{port!s} or controller output {port}")
        elif ports[VEHICLE].get(f"{DAMPER_PORT}_{port}") == "input":
            connections.append(Connection(DAMPER, port, VEHICLE, f"{DAMPER_PORT}_{port}"))
        else:
            raise missing(DAMPER, port, f"vehicle input {DAMPER_PORT}_{port}")
    for port, causality in ports[CONTROLLER].items():
        if causality == "input":
            if port not in vehicle_out:
                raise missing(CONTROLLER, port, f"vehicle output {port}")
            connections.append(Connection(VEHICLE, port, CONTROLLER, port))
        elif ports[DAMPER].get(port) != "input":
            raise missing(CONTROLLER, port, f"damper input {port}")
    fed = {(c.end_element, c.end_connector) for c in connections}
    if (VEHICLE, f"{DAMPER_PORT}_force") not in fed:
        raise missing(VEHICLE, f"{DAMPER_PORT}_force", "damper output force")
    elements = [
        Element(element, os.path.relpath(path, base), tuple(Connector(p, c) for p, c in ports[element].items()))
        for element, path in paths.items()
    ]
    return SystemStructure(name=name, elements=elements, connections=connections, base=base)


def write_closed_loop(
    folder: Path, vehicle_fmu: Path, damper_fmu: Path, controller_fmu: Path, name: str = "semi-active quarter car"
) -> Path:
    """`closed_loop_system` written as `folder`/SystemStructure.ssd; return its path."""
    return write_ssd(
        closed_loop_system(vehicle_fmu, damper_fmu, controller_fmu, folder, name), folder / "SystemStructure.ssd"
    )
