"""Quarter car on one actuator post: sprung and unsprung mass, spring and damper between, tyre to the post.

The thesis's single-corner experiment. Built from one corner (front by default) of a full-vehicle parameter file:
the sprung mass is that corner's share of the body mass (axle load split by the centre of gravity, halved), the spring
and damper act vertically with the vertical share of the corner's strut line. Coordinates are displacements from the
design position, which is the static equilibrium: the spring carries the sprung weight, the tyre the corner's weight.
"""

from __future__ import annotations

from collections.abc import Mapping


from .assembly import Assembly, Deflection
from .components import REFERENCE, STABILISED, resolve_components
from .errors import VehicleModelError
from .linear import LinearVehicle
from .parameters import VehicleParameters
from .ports import VehiclePort, actuator_ports, damper_input, damper_outputs
from .reference import LinearSpring, SplineDamper

COMPONENTS = ["damper"]


def corner_sprung_mass(params: VehicleParameters, axle: str) -> float:
    """Share of the body mass [kg] that one corner of `axle` ('front' or 'rear') carries statically."""
    body = params.body
    lever = body.cog_to_rear_axle if axle == "front" else body.cog_to_front_axle
    return body.mass * lever / body.wheelbase / 2.0


def build_quarter_car(
    params: VehicleParameters, components: Mapping[str, str] | None = None, axle: str = "front"
) -> LinearVehicle:
    """Quarter car of `axle`; `components={'damper': 'reference'}` closes the damper loop with the built-in damper."""
    if axle not in ("front", "rear"):
        raise VehicleModelError(f"quarter car: axle {axle!r}; expected 'front' or 'rear'")
    choice = resolve_components("quarter car", COMPONENTS, components)
    corner = params.front if axle == "front" else params.rear
    damper = params.front_damper if axle == "front" else params.rear_damper
    sprung = corner_sprung_mass(params, axle)
    g = params.gravity
    s_z = float(corner.strut_unit[2])
    coords = [
        VehiclePort("body_displacement", "m", "vertical displacement of the sprung mass from the design position"),
        VehiclePort("spindle_displacement", "m", "vertical displacement of the unsprung mass from the design position"),
    ]
    asm = Assembly(coords, posts=["post"], gravity=g)
    body, wheel = asm.unit_row(0), asm.unit_row(1)
    asm.add_point_mass(sprung, body)
    asm.add_point_mass(corner.unsprung_mass, wheel)
    strut = Deflection(s_z * (body - wheel), asm.post_row())
    asm.add_spring(strut, LinearSpring(corner.spring_rate / s_z**2, 0.0, preload=-sprung * g / s_z))
    tyre = Deflection(-wheel, asm.post_row("post"))
    tyre_spring = LinearSpring(corner.tyre_stiffness, corner.tyre_damping, preload=(sprung + corner.unsprung_mass) * g)
    asm.add_spring(tyre, tyre_spring)
    stroke = Deflection(corner.damper_ratio * strut.row, asm.post_row())
    if choice["damper"] == REFERENCE and damper.model == "linear":
        asm.add_spring(stroke, LinearSpring(0.0, damper.damping))
    elif choice["damper"] == REFERENCE:
        asm.add_feedback("damper", stroke, SplineDamper(damper.velocity, damper.force))
    else:
        stabiliser = LinearSpring(0.0, damper.damping) if choice["damper"] == STABILISED else None
        asm.add_force_input(damper_input(""), stroke, stabiliser)
    for port, kind in zip(damper_outputs(""), ("displacement", "velocity")):
        asm.add_output(port, kind, stroke)
    asm.add_output(coords[0], "displacement", Deflection(body, asm.post_row()))
    asm.add_output(coords[1], "displacement", Deflection(wheel, asm.post_row()))
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
        f"quarter car ({axle} corner) of {params.name}: sprung {sprung:.1f} kg, unsprung {corner.unsprung_mass:.1f} kg"
    )
    return asm.to_vehicle(f"quarter_car_{axle}", description, actuator_ports(""))
