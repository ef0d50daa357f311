"""The drive binding of a road test: the vehicle's actuator ports read the drive-file channels of their names."""

from __future__ import annotations

from nnfmu.cosim import DriveBinding, DriveInputError, SystemStructure, bind_free_inputs, free_inputs
from nnfmu.vehicle import CORNERS, actuator_ports

ACTUATOR_INPUTS = frozenset(port.name for corner in CORNERS for port in actuator_ports(corner))


def vehicle_binding(system: SystemStructure) -> DriveBinding:
    """Bind the free actuator inputs of the one vehicle element (a quarter car has its corner's, a full vehicle all
    four posts') to the drive's channels of the same names. A system without a vehicle element falls back on the
    master's default (the one element with free inputs reads the channels of their names); two vehicle elements, or
    a vehicle with other free inputs, raise DriveInputError naming them."""
    free = free_inputs(system)
    vehicles = {name: [n for n in inputs if n in ACTUATOR_INPUTS] for name, inputs in free.items()}
    vehicles = {name: ports for name, ports in vehicles.items() if ports}
    if not vehicles:
        return bind_free_inputs(system)
    if len(vehicles) > 1:
        raise DriveInputError(
            f"system {system.name!r}: one four-poster drives one vehicle; elements with free "
            f"actuator inputs: {', '.join(vehicles)}"
        )
    ((element, ports),) = vehicles.items()
    return DriveBinding.by_name(element, ports)
