"""Quarter car on one actuator post: sprung and unsprung mass, spring and damper between, tyre to the post.

The thesis's single-corner experiment, built from `QuarterCarParameters` (a quarter-car file, or one corner of a
full-vehicle file). Everything moves vertically: the spring acts with its wheel rate on the wheel travel relative to
the body (body minus wheel), the damper's stroke is `damper_motion_ratio` times that travel (rebound positive) and
its force acts back on wheel and body times the same ratio; no tilt enters beyond the ratio the parameters state.
Coordinates are displacements from the design position, which is the static equilibrium: the spring carries the
sprung weight, the tyre the corner's weight. The actuator inputs are named after the corner the quarter car stands
on (`actuator_fl_displacement`), so a four-poster drive file feeds them by name.
"""

from __future__ import annotations

from collections.abc import Mapping

from nnfmu.vehicle.dynamics.assembly import Assembly, Deflection
from nnfmu.vehicle.dynamics.builtin_elements import LinearSpring, SplineDamper
from nnfmu.vehicle.dynamics.components import REFERENCE, STABILISED, resolve_components
from nnfmu.vehicle.dynamics.linear import LinearVehicle
from nnfmu.vehicle.dynamics.ports import VehiclePort, actuator_ports, damper_input, damper_outputs
from nnfmu.vehicle.dynamics.quarter_car_parameters import QuarterCarParameters

COMPONENTS = ["damper"]


def build_quarter_car(
    params: QuarterCarParameters,
    components: Mapping[str, str] | None = None,
    stabilisers: Mapping[str, LinearSpring] | None = None,
) -> LinearVehicle:
    """Quarter car of `params`; `components={'damper': 'reference'}` closes the damper loop with the built-in damper;
    `stabilisers={'damper_force': ...}` replaces a stabilised damper port's reference element."""
    choice = resolve_components("quarter car", COMPONENTS, components)
    stabilisers = dict(stabilisers or {})
    damper = params.damper
    sprung, g = params.sprung_mass, params.gravity
    coords = [
        VehiclePort("body_displacement", "m", "vertical displacement of the sprung mass from the design position"),
        VehiclePort("spindle_displacement", "m", "vertical displacement of the unsprung mass from the design position"),
    ]
    asm = Assembly(coords, posts=[params.corner], gravity=g)
    body, wheel = asm.unit_row(0), asm.unit_row(1)
    asm.add_point_mass(sprung, body)
    asm.add_point_mass(params.unsprung_mass, wheel)
    travel = Deflection(body - wheel, asm.post_row())
    asm.add_spring(travel, LinearSpring(params.wheel_rate, 0.0, preload=-sprung * g))
    tyre = Deflection(-wheel, asm.post_row(params.corner))
    tyre_spring = LinearSpring(params.tyre_stiffness, params.tyre_damping, preload=(sprung + params.unsprung_mass) * g)
    asm.add_spring(tyre, tyre_spring)
    stroke = Deflection(params.damper_motion_ratio * travel.row, asm.post_row())
    if choice["damper"] == REFERENCE and damper.model == "linear":
        asm.add_spring(stroke, LinearSpring(0.0, damper.damping))
    elif choice["damper"] == REFERENCE:
        asm.add_feedback("damper", stroke, SplineDamper(damper.velocity, damper.force))
    else:
        port = damper_input("")
        reference = LinearSpring(0.0, damper.damping)
        stabiliser = stabilisers.get(port.name, reference) if choice["damper"] == STABILISED else None
        asm.add_force_input(port, stroke, stabiliser)
    for port, kind in zip(damper_outputs(""), ("displacement", "velocity")):
        asm.add_output(port, kind, stroke)
    asm.add_output(coords[0], "displacement", Deflection(body, asm.post_row()))
    asm.add_output(coords[1], "displacement", Deflection(wheel, asm.post_row()))
    asm.add_output(
        VehiclePort(
            "body_velocity",
            "m/s",
            "absolute vertical velocity of the sprung mass, up positive (a skyhook controller's sensor)",
        ),
        "velocity",
        Deflection(body, asm.post_row()),
    )
    asm.add_output(
        VehiclePort("body_acceleration", "m/s^2", "vertical acceleration of the sprung mass"),
        "acceleration",
        Deflection(body, asm.post_row()),
    )
    asm.add_output(
        VehiclePort("spindle_acceleration", "m/s^2", "vertical acceleration of the unsprung mass"),
        "acceleration",
        Deflection(wheel, asm.post_row()),
    )
    asm.add_output(
        VehiclePort(
            "spindle_vertical_force", "N", "tyre force on the spindle, up (compression) positive, static load included"
        ),
        "force",
        tyre,
        tyre_spring,
    )
    description = (
        f"quarter car ({params.corner} corner) of {params.name}: sprung {sprung:.1f} kg, unsprung "
        f"{params.unsprung_mass:.1f} kg, wheel rate {params.wheel_rate:.0f} N/m, damper motion ratio "
        f"{params.damper_motion_ratio:.4f}"
    )
    return asm.to_vehicle(f"quarter_car_{params.corner}", description, actuator_ports(params.corner))
