"""Named, unit-carrying ports of a vehicle model, named like drive-file and rig channels."""

from __future__ import annotations

from dataclasses import dataclass

from nnfmu.kinds import kind_of
from nnfmu.vehicle.dynamics.errors import VehicleModelError

CORNERS = ("fl", "fr", "rl", "rr")


@dataclass(frozen=True)
class VehiclePort:
    """One scalar input or output: channel-style name, SI unit and what it is (sign convention included)."""

    name: str
    unit: str
    description: str


def actuator_ports(corner: str) -> list[VehiclePort]:
    """Displacement and velocity inputs of the actuator post under `corner` (named like the drive file's channels)."""
    return [
        VehiclePort(
            f"actuator_{corner}_displacement",
            "m",
            f"vertical displacement of the {corner} post from its rest position, up positive",
        ),
        VehiclePort(
            f"actuator_{corner}_velocity",
            "m/s",
            f"vertical velocity of the {corner} post, up positive (the rate of the displacement)",
        ),
    ]


def damper_input(tag: str) -> VehiclePort:
    name = f"damper_{tag}_force" if tag else "damper_force"
    return VehiclePort(name, "N", "damper force along its axis, rebound (tension, resisting extension) positive")


def damper_outputs(tag: str) -> list[VehiclePort]:
    prefix = f"damper_{tag}_" if tag else "damper_"
    return [
        VehiclePort(
            f"{prefix}displacement", "m", "damper stroke from the design position, rebound (extension) positive"
        ),
        VehiclePort(f"{prefix}velocity", "m/s", "damper stroke velocity, rebound (extension) positive"),
    ]


def bushing_inputs(name: str) -> list[VehiclePort]:
    """Force/torque inputs of bushing `name` (e.g. 'bushing_fl_front'): what the bushing needs to hold its
    deflection."""
    return [
        VehiclePort(
            f"{name}_axial_force", "N", "bushing force along its axis, same sign as the axial displacement for a spring"
        ),
        VehiclePort(
            f"{name}_radial_force",
            "N",
            "bushing force along its radial direction, same sign as the radial displacement for a spring",
        ),
        VehiclePort(
            f"{name}_axial_torque", "N.m", "bushing torque about its axis, same sign as the axial rotation for a spring"
        ),
        VehiclePort(
            f"{name}_conical_torque",
            "N.m",
            "bushing torque tilting its axis, same sign as the conical rotation for a spring",
        ),
    ]


def bushing_outputs(name: str) -> list[VehiclePort]:
    """Deflection outputs of bushing `name`: the arm's inner sleeve relative to the body's outer sleeve."""
    return [
        VehiclePort(f"{name}_axial_displacement", "m", "inner relative to outer sleeve along the bushing axis"),
        VehiclePort(f"{name}_axial_velocity", "m/s", "rate of the axial displacement"),
        VehiclePort(f"{name}_radial_displacement", "m", "inner relative to outer sleeve along the radial direction"),
        VehiclePort(f"{name}_radial_velocity", "m/s", "rate of the radial displacement"),
        VehiclePort(f"{name}_axial_rotation", "rad", "inner relative to outer sleeve about the bushing axis (torsion)"),
        VehiclePort(f"{name}_axial_angular_velocity", "rad/s", "rate of the axial rotation"),
        VehiclePort(f"{name}_conical_rotation", "rad", "tilt of the inner sleeve's axis towards the radial direction"),
        VehiclePort(f"{name}_conical_angular_velocity", "rad/s", "rate of the conical rotation"),
    ]


def component_channels(component: str) -> list[tuple[str, str, str]]:
    """(force input, displacement output, rate output) port names of a component such as 'bushing_fl_front', its
    channels those of its kind (`nnfmu.kinds`); VehicleModelError for a name of no registered kind."""
    kind = kind_of(component)
    if kind is None:
        raise VehicleModelError(f"{component!r} is no element of a registered component kind (nnfmu.kinds)")
    return kind.port_channels(component)
