"""Which inputs of a system the drive feeds: the master's only link to the outside, built by whoever sets up the run.

An SSP system's elements talk to each other through its connections; the inputs no connection reaches are the
system's boundary. A `DriveBinding` says which element stands on that boundary and which drive channel each of its
free inputs reads. The master knows nothing else about the driven element: a road-test workflow binds a vehicle's
actuator ports, a rig workflow could bind a component's motion inputs the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

from nnfmu.cosim.drive_inputs import DriveInputError
from nnfmu.cosim.port_derivatives import derivative_inputs
from nnfmu.cosim.ssp import SystemStructure


@dataclass(frozen=True)
class DriveBinding:
    """The driven `element`, its free `inputs` and the drive `channels` they read, pairwise (SI units both sides)."""

    element: str
    inputs: tuple[str, ...]
    channels: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.inputs) != len(self.channels):
            raise DriveInputError(
                f"element {self.element!r}: {len(self.inputs)} inputs but {len(self.channels)} drive "
                "channels; each input reads exactly one channel"
            )
        if len(set(self.inputs)) != len(self.inputs):
            raise DriveInputError(f"element {self.element!r}: an input is bound twice in {self.inputs}")

    @classmethod
    def by_name(cls, element: str, inputs: tuple[str, ...] | list[str]) -> DriveBinding:
        """`inputs` of `element`, each reading the drive channel of the same name."""
        return cls(element, tuple(inputs), tuple(inputs))


def free_inputs(system: SystemStructure) -> dict[str, list[str]]:
    """Every element's inputs that no connection of `system` reaches, in FMU order (elements without any left out),
    less the port derivative inputs the master sets itself (`port_derivatives.py`)."""
    from fmpy import read_model_description

    connected = {(c.end_element, c.end_connector) for c in system.connections}
    free: dict[str, list[str]] = {}
    for element in system.elements:
        inputs = [
            v.name
            for v in read_model_description(str(system.fmu_path(element))).modelVariables
            if v.causality == "input"
        ]
        own = derivative_inputs(inputs)
        names = [n for n in inputs if (element.name, n) not in connected and n not in own]
        if names:
            free[element.name] = names
    return free


def bind_free_inputs(system: SystemStructure) -> DriveBinding:
    """The default binding of a plain SSP master: the one element with free inputs reads them from the drive channels
    of the same names. No element, or several, with free inputs: DriveInputError naming them."""
    free = free_inputs(system)
    if len(free) != 1:
        listed = "; ".join(f"{name}: {', '.join(inputs)}" for name, inputs in free.items()) or "none"
        raise DriveInputError(
            f"system {system.name!r}: the drive feeds the free inputs of exactly one element; "
            f"elements with free inputs: {listed}"
        )
    ((element, inputs),) = free.items()
    return DriveBinding.by_name(element, inputs)
