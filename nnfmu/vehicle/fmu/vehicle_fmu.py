"""`nnfmu vehicle build`: a quarter car or full vehicle as a native FMI co-simulation FMU, via the component factory.

The vehicle's exact discrete step becomes an ONNX step graph (`step_graph`) with a `Component` attached: input ports are
the vehicle's inputs (actuator displacements and velocities, forces of external components), output ports its outputs,
the state starts at the static equilibrium for zero actuator input (or the settings' initial state), and the output
filter is off (an exact model must not be low-passed). The component interpolates its inputs (`interval_starts`), and
`nnfmu.fmu.build.build_fmu_from_model` turns the graph, in memory, into a native FMU like any trained component, so the
FMU semantics are those of docs/fmu.md: samples at t_start + k T; the inputs are linear between samples, from the values
set at one sample's time to those set at the next; a sample in a step takes the inputs set before the step (plus their
FMI 2 derivatives times the time into the step); inputs set at the latest sample's time make the FMU evaluate that
sample again, so the outputs there (accelerations, tyre forces) follow the component forces set there.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx

import nnfmu
from nnfmu.component import Component, Port, StatePort
from nnfmu.fmu import BuildOptions, build_fmu_from_model
from nnfmu.vehicle.dynamics import (
    DEFAULT_FILE,
    LinearVehicle,
    QuarterCarParameters,
    VehicleModelError,
    VehicleParameters,
)
from nnfmu.vehicle.dynamics.builtin_elements import LinearSpring
from nnfmu.vehicle.dynamics.components import STABILISED
from nnfmu.vehicle.dynamics.full_vehicle import build_full_vehicle
from nnfmu.vehicle.dynamics.linear import DiscreteVehicle
from nnfmu.vehicle.dynamics.port_gains import GainCorrection, gain_correction
from nnfmu.vehicle.dynamics.ports import CORNERS, component_channels
from nnfmu.vehicle.dynamics.quarter_car import build_quarter_car
from nnfmu.vehicle.fmu.errors import VehicleBuildError
from nnfmu.vehicle.fmu.settings import MAX_SUBSTEP, MODELS, VehicleBuildSettings
from nnfmu.vehicle.fmu.step_graph import (
    FIRST_IN,
    FIRST_OUT,
    GAINS,
    GAINS_START,
    INPUTS,
    INPUTS_START,
    OUTPUTS,
    STATE_IN,
    STATE_OUT,
    discrete_step_graph,
)


def vehicle_model(model: str, settings: VehicleBuildSettings) -> LinearVehicle:
    """The quarter car or full vehicle of `settings`' parameter file with its component choices."""
    if model not in MODELS:
        raise VehicleBuildError(f"unknown vehicle model {model!r}; choose one of {', '.join(MODELS)}")
    path = settings.params_path or DEFAULT_FILE
    stabilisers = {name: LinearSpring(*value) for name, value in settings.stabilisers.items()}
    if model == "quarter-car":
        vehicle = build_quarter_car(QuarterCarParameters.load(path, settings.corner), settings.components, stabilisers)
    elif settings.corner is not None:
        raise VehicleBuildError(f"corner {settings.corner!r}: only a quarter car stands on one corner")
    else:
        vehicle = build_full_vehicle(VehicleParameters.load(path), settings.components, stabilisers)
    stabilised = {p.name for p, held in zip(vehicle.inputs, vehicle.stabilised_inputs) if held}
    unused = sorted(set(stabilisers) - stabilised)
    if unused:
        raise VehicleBuildError(
            f"{vehicle.name}: stabiliser(s) for {', '.join(unused)}, which are not stabilised force ports "
            f"(stabilised: {', '.join(sorted(stabilised)) or 'none'}; choose 'stabilised' for their component)"
        )
    return vehicle


def initial_state(vehicle: LinearVehicle) -> tuple[float, ...]:
    """Static equilibrium for zero inputs; the design position (all zero) when external bushings carry the only
    stiffness of some motion, since the rest position then depends on the components the master connects."""
    try:
        return tuple(float(v) for v in vehicle.equilibrium())
    except VehicleModelError:
        return (0.0,) * len(vehicle.states)


def _start(vehicle: LinearVehicle, settings: VehicleBuildSettings) -> tuple[float, ...]:
    """The state the FMU starts in: `settings.initial_state` when given (checked for the state's length), else
    `initial_state`."""
    if settings.initial_state is None:
        return initial_state(vehicle)
    if len(settings.initial_state) != len(vehicle.states):
        raise VehicleBuildError(
            f"{vehicle.name}: initial state has {len(settings.initial_state)} values; the "
            f"vehicle has {len(vehicle.states)} states"
        )
    return tuple(float(v) for v in settings.initial_state)


GIVEN = "_given"  # suffix of the flag input that switches one element input on


def _per(force_unit: str, motion_unit: str) -> str:
    """The unit of a force per motion: 'N' per 'm' -> 'N/m', per 'm/s' -> 'N.s/m' (likewise N.m per rad)."""
    if motion_unit.endswith("/s"):
        return f"{force_unit}.s/{motion_unit.removesuffix('/s')}"
    return f"{force_unit}/{motion_unit}"


def gain_ports(discrete: DiscreteVehicle, gains: GainCorrection, settings: VehicleBuildSettings) -> list[Port]:
    """The inputs of the `port_gains` tensor: `P_per_D` (stiffness) for every stabilised port P, then `P_per_V`
    (damping), D and V its deflection and rate outputs, then each one's flag `P_per_D_given`, `P_per_V_given`."""
    vehicle = discrete.vehicle
    motions = {
        force: (disp, rate)
        for name, choice in settings.components.items()
        if choice == STABILISED
        for force, disp, rate in component_channels(name)
    }
    units = {o.name: o.unit for o in vehicle.outputs}
    values: list[list[tuple[str, str, str]]] = [[], []]
    for j, p in enumerate(gains.ports):
        port = vehicle.inputs[p]
        for kind, (what, motion) in enumerate(zip(("stiffness", "damping"), motions[port.name])):
            name = f"{port.name}_per_{motion}"
            text = (
                f"local {what} of the component on {port.name} (d {port.name} / d {motion}) for the step from now, "
                f"used while {name}{GIVEN} = 1, below 0 taken as 0 (else the fitted {gains.fitted[j, kind]:.9g})"
            )
            values[kind].append((name, _per(port.unit, units[motion]), text))
    given = [
        Port(f"{name}{GIVEN}", "1", f"1: {name} replaces the fitted element from the next step; 0 (default): not")
        for name, _, _ in [*values[0], *values[1]]
    ]
    ports = [Port(name, unit, text) for name, unit, text in [*values[0], *values[1]]] + given
    return [Port(p.name, p.unit, p.description, GAINS, i) for i, p in enumerate(ports)]


def port_gain_correction(discrete: DiscreteVehicle) -> GainCorrection:
    """The correction of `discrete`'s stabilised ports for elements given per step (VehicleBuildError: none)."""
    vehicle = discrete.vehicle
    if not np.any(vehicle.stabilised_inputs):
        raise VehicleBuildError(f"{vehicle.name}: port derivatives asked for, but no force port is stabilised")
    return gain_correction(
        vehicle.stabilised_A, vehicle.B, vehicle.stabiliser_rows, vehicle.stabiliser_elements, discrete.dt
    )


def vehicle_component(
    discrete: DiscreteVehicle, model: str, settings: VehicleBuildSettings, gains: GainCorrection | None = None
) -> Component:
    """The component description of the step graph of `discrete`: ports with units, state, period, no filter (and
    with `gains`, the stabilised ports' element inputs)."""
    vehicle = discrete.vehicle
    external = [p.name for p in vehicle.inputs if not p.name.startswith("actuator")]
    extra = gain_ports(discrete, gains, settings) if gains is not None else []
    return Component(
        name=vehicle.name,
        inputs=[Port(p.name, p.unit, p.description, INPUTS, i) for i, p in enumerate(vehicle.inputs)] + extra,
        outputs=[Port(p.name, p.unit, p.description, OUTPUTS, i) for i, p in enumerate(vehicle.outputs)],
        states=[
            StatePort(STATE_IN, STATE_OUT, _start(vehicle, settings), "vehicle state [q, q'] (names in the metadata)"),
            StatePort(FIRST_IN, FIRST_OUT, (1.0,), "1 before sample 0 (which reports the initial state), then 0"),
        ],
        sample_period=discrete.dt,
        description=vehicle.description,
        filter_cutoff=0.0,
        interval_starts={INPUTS: INPUTS_START} | ({GAINS: GAINS_START} if gains is not None else {}),
        metadata={
            "producer": f"nnfmu {nnfmu.__version__} vehicle build",
            "model": model,
            "parameters": str(settings.params_path or DEFAULT_FILE),
            "components": settings.components,
            "stabilisers": {name: list(value) for name, value in settings.stabilisers.items()},
            "corners": [c for c in CORNERS if f"actuator_{c}_displacement" in vehicle.input_names],
            "external_force_inputs": external,
            "reference_dampers": vehicle.feedback_names,
            "hold": discrete.hold,
            "substeps": discrete.substeps,
            "states": [f"{p.name} [{p.unit}]" for p in vehicle.states],
        },
    )


def vehicle_step_graph(model: str, settings: VehicleBuildSettings) -> onnx.ModelProto:
    """The ONNX step graph of `model` at `settings.sample_period`, its `Component` attached."""
    vehicle = vehicle_model(model, settings)
    discrete = vehicle.discretise(settings.sample_period, "foh", MAX_SUBSTEP)
    gains = port_gain_correction(discrete) if settings.port_derivatives else None
    graph = discrete_step_graph(discrete, gains)
    vehicle_component(discrete, model, settings, gains).attach_to(graph)
    return graph


def build_vehicle_fmu(model: str, out: Path, settings: VehicleBuildSettings | None = None) -> Path:
    """Build the FMU of `model` ('quarter-car' or 'full-vehicle') at `out`; return its path. Raises FmuBuildError
    (build), VehicleBuildError (settings) or ParameterError (parameter file); no partial `.fmu` is left."""
    settings = settings or VehicleBuildSettings()
    options = BuildOptions(
        out=Path(out), backend=settings.backend, fmi_version=settings.fmi_version, platforms=settings.platforms
    )
    return build_fmu_from_model(vehicle_step_graph(model, settings), options)
