"""Full vehicle on a four-poster: body heave/pitch/roll, front lower control arms on two bushings each, four corners.

Linear multibody model about the design position (small motions; every deflection is a linear function of the
coordinates, so geometry is frozen at design):
- body: heave, roll, pitch (x, y and yaw held by the rig's restraints);
- front corners (MacPherson-like): the LCA is a rigid body with 6 small-motion coordinates, held to the body by its
  front and rear bushings (6 directions each); the knuckle and wheel are a point mass carried at the LCA's ball joint;
  the spring and damper act along the strut line from the ball joint to the body top mount; so wheel travel turns the
  LCA about its pivot line (angle ~ wheel travel / arm length) and deflects both bushings as the geometry dictates;
- rear corners: the wheel moves vertically only, the spring and damper act along the (vertical) strut line;
- tyres: a vertical spring and damper from the spindle to the actuator post; lift-off is not modelled (the tyre pulls).
Springs hold the sprung weight and tyres the corner weight at design; what remains (LCA weight, horizontal parts of
the inclined strut preload) sets small static bushing deflections (see `LinearVehicle.equilibrium`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from nnfmu.vehicle.dynamics.assembly import Assembly, Deflection, RigidMotion
from nnfmu.vehicle.dynamics.builtin_elements import LinearSpring, SplineDamper
from nnfmu.vehicle.dynamics.components import REFERENCE, STABILISED, resolve_components
from nnfmu.vehicle.dynamics.geometry import SIDES, BushingFrame, mirror_point, mirror_rotation, unit
from nnfmu.vehicle.dynamics.linear import LinearVehicle
from nnfmu.vehicle.dynamics.parameters import (
    AxleParameters,
    BushingParameters,
    DamperParameters,
    VehicleParameters,
    corner_sprung_mass,
)
from nnfmu.vehicle.dynamics.ports import (
    CORNERS,
    VehiclePort,
    actuator_ports,
    bushing_inputs,
    bushing_outputs,
    damper_input,
    damper_outputs,
)

FRONT_CORNERS = ("fl", "fr")
REAR_CORNERS = ("rl", "rr")
BUSHINGS = ("front", "rear")
COMPONENTS = [f"damper_{c}" for c in CORNERS] + [f"bushing_{c}_{b}" for c in FRONT_CORNERS for b in BUSHINGS]
LCA_COORDINATES = (
    ("translation_x", "m"), ("translation_y", "m"), ("translation_z", "m"),
    ("rotation_x", "rad"), ("rotation_y", "rad"), ("rotation_z", "rad"),
)  # fmt: skip


def _coordinates() -> list[VehiclePort]:
    coords = [
        VehiclePort("body_heave", "m", "vertical displacement of the body's centre of gravity, up positive"),
        VehiclePort("body_roll", "rad", "body rotation about x, right side down positive"),
        VehiclePort("body_pitch", "rad", "body rotation about y, nose down positive"),
    ]
    for corner in FRONT_CORNERS:
        coords += [
            VehiclePort(f"lca_{corner}_{name}", unit_, f"small motion of the {corner} LCA's centre of mass ({name})")
            for name, unit_ in LCA_COORDINATES
        ]
    coords += [
        VehiclePort(f"spindle_{c}_displacement", "m", f"vertical displacement of the {c} wheel, up positive")
        for c in REAR_CORNERS
    ]
    return coords


def build_full_vehicle(
    params: VehicleParameters,
    components: Mapping[str, str] | None = None,
    stabilisers: Mapping[str, LinearSpring] | None = None,
) -> LinearVehicle:
    """Full vehicle; `components` maps e.g. 'damper_fl' or 'bushing_fl_front' to 'external' (default), 'reference'
    or 'stabilised' (external, stabilised by the reference element: the linear damping or bushing); `stabilisers`
    replaces a stabilised force port's reference element, by input port name ('bushing_fl_front_radial_force')."""
    choice = resolve_components("full vehicle", COMPONENTS, components)
    stabilisers = dict(stabilisers or {})
    coords = _coordinates()
    asm = Assembly(coords, posts=list(CORNERS), gravity=params.gravity)
    index = {c.name: i for i, c in enumerate(coords)}
    rows = {name: asm.unit_row(i) for name, i in index.items()}
    zero = np.zeros(asm.size)
    body = RigidMotion(
        translation=np.array([zero, zero, rows["body_heave"]]),
        rotation=np.array([rows["body_roll"], rows["body_pitch"], zero]),
        origin=np.zeros(3),
    )
    b = params.body
    asm.add_point_mass(b.mass, body.translation[2])
    asm.add_inertia(np.diag([b.roll_inertia, b.pitch_inertia]), body.rotation[:2])
    for corner in CORNERS:
        side = SIDES[corner[1]]
        front = corner[0] == "f"
        axle = params.front if front else params.rear
        damper = params.front_damper if front else params.rear_damper
        if front:
            lca = _add_lca(asm, params, corner, side, body, rows, choice, stabilisers)
            wheel = lca.point(mirror_point(params.lca.ball_joint, side))
            extra_mass = params.lca.mass
        else:
            wheel = np.array([zero, zero, rows[f"spindle_{corner}_displacement"]])
            extra_mass = 0.0
        asm.add_point_mass(axle.unsprung_mass, wheel if front else wheel[2])
        sprung_load = corner_sprung_mass(params, "front" if front else "rear") * params.gravity
        _add_corner(
            asm,
            corner,
            side,
            axle,
            damper,
            choice[f"damper_{corner}"],
            body,
            wheel,
            sprung_load,
            extra_mass,
            stabilisers,
        )
        x_axle = b.cog_to_front_axle if front else -b.cog_to_rear_axle
        track = b.track_front if front else b.track_rear
        corner_point = body.point(np.array([x_axle, side * track / 2.0, 0.0]))
        asm.add_output(
            VehiclePort(
                f"body_acceleration_{corner}", "m/s^2", f"vertical acceleration of the body above the {corner} wheel"
            ),
            "acceleration",
            Deflection(corner_point[2], asm.post_row()),
        )
    for name, row, unit_ in (
        ("heave", "body_heave", "m/s^2"),
        ("roll", "body_roll", "rad/s^2"),
        ("pitch", "body_pitch", "rad/s^2"),
    ):
        asm.add_output(
            VehiclePort(f"body_acceleration_{name}", unit_, f"body {name} acceleration"),
            "acceleration",
            Deflection(rows[row], asm.post_row()),
        )
    for name, row in (("heave", "body_heave"), ("roll", "body_roll"), ("pitch", "body_pitch")):
        asm.add_output(coords[index[row]], "displacement", Deflection(rows[row], asm.post_row()))
    posts = [actuator_ports(c)[0] for c in CORNERS] + [actuator_ports(c)[1] for c in CORNERS]
    description = f"full vehicle of {params.name} on a four-poster (linear about the design position)"
    return asm.to_vehicle("full_vehicle", description, posts)


def _add_corner(
    asm: Assembly,
    corner: str,
    side: float,
    axle: AxleParameters,
    damper: DamperParameters,
    choice: str,
    body: RigidMotion,
    wheel: np.ndarray,
    sprung_load: float,
    extra_mass: float,
    stabilisers: Mapping[str, LinearSpring],
) -> None:
    """Spring, damper (port or reference), tyre and the corner's spindle outputs."""
    s = mirror_point(axle.strut_unit, side)
    top = mirror_point(axle.strut_top, side)
    strut = Deflection(s @ (body.point(top) - wheel), asm.post_row())
    asm.add_spring(strut, LinearSpring(axle.strut_spring_rate, 0.0, preload=-sprung_load / s[2]))
    stroke = Deflection(axle.damper_ratio * strut.row, asm.post_row())
    if choice == REFERENCE and damper.model == "linear":
        asm.add_spring(stroke, LinearSpring(0.0, damper.damping))
    elif choice == REFERENCE:
        asm.add_feedback(f"damper_{corner}", stroke, SplineDamper(damper.velocity, damper.force))
    else:
        port = damper_input(corner)
        stabiliser = stabilisers.get(port.name, LinearSpring(0.0, damper.damping)) if choice == STABILISED else None
        asm.add_force_input(port, stroke, stabiliser)
    for port, kind in zip(damper_outputs(corner), ("displacement", "velocity")):
        asm.add_output(port, kind, stroke)
    tyre = Deflection(-wheel[2], asm.post_row(corner))
    corner_load = sprung_load + (axle.unsprung_mass + extra_mass) * asm.gravity
    tyre_spring = LinearSpring(axle.tyre_stiffness, axle.tyre_damping, preload=corner_load)
    asm.add_spring(tyre, tyre_spring)
    spindle = Deflection(wheel[2], asm.post_row())
    asm.add_output(
        VehiclePort(f"spindle_{corner}_displacement", "m", "vertical spindle displacement, up positive"),
        "displacement",
        spindle,
    )
    asm.add_output(
        VehiclePort(f"spindle_{corner}_acceleration", "m/s^2", "vertical spindle acceleration, up positive"),
        "acceleration",
        spindle,
    )
    asm.add_output(
        VehiclePort(
            f"spindle_{corner}_vertical_force",
            "N",
            "tyre force on the spindle, up (compression) positive, static load included",
        ),
        "force",
        tyre,
        tyre_spring,
    )


def _add_lca(
    asm: Assembly,
    params: VehicleParameters,
    corner: str,
    side: float,
    body: RigidMotion,
    rows: dict[str, np.ndarray],
    choice: Mapping[str, str],
    stabilisers: Mapping[str, LinearSpring],
) -> RigidMotion:
    """The LCA of a front corner: mass, inertia, both bushings (ports or reference) and its angle output."""
    p = params.lca
    names = [f"lca_{corner}_{name}" for name, _ in LCA_COORDINATES]
    lca = RigidMotion(
        translation=np.array([rows[n] for n in names[:3]]),
        rotation=np.array([rows[n] for n in names[3:]]),
        origin=mirror_point(p.centre_of_mass, side),
    )
    asm.add_point_mass(p.mass, lca.translation)
    asm.add_inertia(np.diag(p.inertia), lca.rotation)
    for position, bushing in zip(BUSHINGS, (p.front_bushing, p.rear_bushing)):
        name = f"bushing_{corner}_{position}"
        _add_bushing(asm, name, bushing, side, body, lca, choice[name], stabilisers)
    pivot = mirror_rotation(unit(np.subtract(p.front_bushing.position, p.rear_bushing.position)), side)
    angle = Deflection(pivot @ (lca.rotation - body.rotation), asm.post_row())
    asm.add_output(
        VehiclePort(
            f"lca_{corner}_angle", "rad", "LCA rotation about its pivot line relative to the body, wheel up positive"
        ),
        "displacement",
        angle,
    )
    asm.add_output(VehiclePort(f"lca_{corner}_angular_velocity", "rad/s", "rate of the LCA angle"), "velocity", angle)
    return lca


def _add_bushing(
    asm: Assembly,
    name: str,
    p: BushingParameters,
    side: float,
    body: RigidMotion,
    lca: RigidMotion,
    choice: str,
    stabilisers: Mapping[str, LinearSpring],
) -> None:
    """One bushing: the four ported directions (ports or linear reference) and the two unported ones (reference)."""
    frame = BushingFrame.of(p.axis, p.radial, side)
    centre = mirror_point(p.position, side)
    moved = lca.point(centre) - body.point(centre)
    turned = lca.rotation - body.rotation
    none = asm.post_row()
    ported = [
        (Deflection(frame.axis @ moved, none), LinearSpring(p.axial_stiffness, p.axial_damping)),
        (Deflection(frame.radial @ moved, none), LinearSpring(p.radial_stiffness, p.radial_damping)),
        (Deflection(frame.rot_axis @ turned, none), LinearSpring(p.torsional_stiffness, p.torsional_damping)),
        (Deflection(frame.rot_conical @ turned, none), LinearSpring(p.conical_stiffness, p.conical_damping)),
    ]
    for port, (deflection, spring) in zip(bushing_inputs(name), ported):
        if choice == REFERENCE:
            asm.add_spring(deflection, spring)
        else:
            asm.add_force_input(port, deflection, stabilisers.get(port.name, spring) if choice == STABILISED else None)
    asm.add_spring(Deflection(frame.lateral @ moved, none), LinearSpring(p.radial_stiffness, p.radial_damping))
    asm.add_spring(Deflection(frame.rot_lateral @ turned, none), LinearSpring(p.conical_stiffness, p.conical_damping))
    out = bushing_outputs(name)
    for i, (deflection, _) in enumerate(ported):
        asm.add_output(out[2 * i], "displacement", deflection)
        asm.add_output(out[2 * i + 1], "velocity", deflection)
