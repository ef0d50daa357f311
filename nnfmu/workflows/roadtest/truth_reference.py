"""Monolithic reference of a road test: the vehicle with its components' truth physics in one fine-step solver.

The components are closed by the rig simulators' own models (`truth_laws`: the damper dyno's and the bushing rig's
physics the networks were trained on), so the reference is the "ground truth" a co-simulation with network FMUs
must approach. The actuator inputs are those the co-simulation master feeds: the drive's displacements and the
rates `derive_rates` takes from them (`nnfmu.cosim.drive_inputs` does the same).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from nnfmu.data import Measurement
from nnfmu.data.derive import derive_rates
from nnfmu.vehicle import (
    ComponentLaw,
    LinearVehicle,
    MonolithicSettings,
    VehicleBuildSettings,
    initial_state,
    rest_state,
    simulate_monolithic,
    truth_laws,
    vehicle_model,
)


@dataclass(frozen=True)
class Reference:
    """The reference run: every vehicle output and component force as a Measurement (SI units), and its cost."""

    measurement: Measurement
    seconds: float


def actuator_inputs(vehicle: LinearVehicle, drive: Measurement) -> dict[str, object]:
    """Arrays of `vehicle`'s actuator inputs from the drive channels of the same names (rates derived), as the
    co-simulation master binds them (a quarter car's inputs name its corner)."""
    rates = derive_rates(drive)
    return {p.name: rates[p.name] for p in vehicle.inputs if p.name.startswith("actuator_")}


def settled_state(
    system: str, components: Mapping[str, str] | None = None, laws: Mapping[str, ComponentLaw] | None = None
) -> tuple[float, ...]:
    """The state every road-test run of `system` starts in: the vehicle at rest on its components' truth physics,
    relaxed (`rest_state`, from the linear equilibrium `initial_state`). The vehicle's own equilibrium stands on its
    linear reference elements; the front LCA's rear bushings carry the front bushing's physics (one set of networks
    serves all four), about twice as stiff as their elements, so a run started there rang at the LCA's ~0.7 kHz
    mode for about 0.1 s with radial bushing rates up to 15x the largest of a vehicle-derived rig drive. `laws`
    (None: the default `truth_laws`) close the force ports instead: a lab car standing on its own physics, solved
    from the rest state on the default laws."""
    vehicle = vehicle_model(system, VehicleBuildSettings(components=dict(components or {})))
    forces = [p.name for p in vehicle.inputs if not p.name.startswith("actuator")]
    state = rest_state(vehicle, truth_laws(forces), np.array(initial_state(vehicle)))
    if laws is not None:
        state = rest_state(vehicle, laws, state)
    return tuple(float(v) for v in state)


def monolithic_reference(
    system: str,
    drive: Measurement,
    components: Mapping[str, str] | None = None,
    step: float = 1e-4,
    compiled: bool = True,
    laws: Mapping[str, ComponentLaw] | None = None,
) -> Reference:
    """Solve `system` ('quarter-car' or 'full-vehicle') with truth laws on every external component under `drive`
    (`components` as for the vehicle FMU: the same ones built in); RK4 at `step` [s], outputs at the drive's sample
    period, from the state the road test's vehicle FMU starts in (`settled_state`: at rest on the truth physics) with
    the components relaxed. `compiled=False`
    solves on the generic per-law path (`simulate_monolithic`), for cross-checks of the compiled kernel. `laws`
    (None: `truth_laws`) close the force ports instead, the run starting at rest on them (a lab car's own physics)."""
    vehicle = vehicle_model(system, VehicleBuildSettings(components=dict(components or {})))
    forces = [p.name for p in vehicle.inputs if not p.name.startswith("actuator")]
    chosen = dict(laws) if laws is not None else truth_laws(forces)
    started = time.perf_counter()
    solved = simulate_monolithic(
        vehicle,
        chosen,
        actuator_inputs(vehicle, drive),
        MonolithicSettings(sample_period=drive.sample_period, step=step, compiled=compiled),
        x0=np.array(settled_state(system, components, chosen)),
    )
    seconds = time.perf_counter() - started
    units = {p.name: p.unit for p in vehicle.outputs + vehicle.inputs}
    channels = {name: values for name, values in solved.items() if name != "time"}
    measurement = Measurement(
        time=drive.time[0] + solved["time"],
        channels=channels,
        units={n: units[n] for n in channels},
        source=f"monolithic reference of the {system} (truth physics, RK4 at {step:g} s) on {drive.source}",
    )
    return Reference(measurement, seconds)
