"""Quarter-car parameters: only what a quarter car has, from a quarter-car TOML file or one corner of a full vehicle.

A quarter car moves vertically only, so every ratio is one number stated at the wheel (relative motion of wheel and
body, wheel up positive):
- the spring by its wheel rate `wheel_rate` [N/m]: vertical force per unit of wheel travel (its motion ratio and
  any tilt are already in the number, as a spring rate is usually quoted);
- the damper along its own stroke (its dyno characteristic, which a damper network models) and its motion ratio
  `damper_motion_ratio` [1]: damper stroke per unit of wheel travel. The damper's force acts on wheel and body times
  the same ratio, so a linear damper of c [N.s/m] damps the wheel with c * ratio^2.
Derived from a full-vehicle corner (`from_vehicle`), the strut's tilt enters spring and damper alike (both lie on
the strut line, which deflects s_z per unit of vertical wheel travel; see `AxleParameters`): the full file's
`spring_rate` is already the rate at the wheel, so wheel_rate = spring_rate, and the damper's stroke per unit of
wheel travel is damper_motion_ratio = damper_ratio * s_z. The sprung mass is the corner's share of the body.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

from nnfmu.vehicle.dynamics.errors import ParameterError, VehicleModelError
from nnfmu.vehicle.dynamics.parameters import (
    DAMPER_MODELS,
    DEFAULT_FILE,
    QUARTER_CAR_TABLE,
    DamperParameters,
    VehicleParameters,
    _Table,
    corner_sprung_mass,
    read_force_velocity_table,
    read_toml,
)
from nnfmu.vehicle.dynamics.ports import CORNERS

DEFAULT_CORNER = "fl"
# keys a full-vehicle file has and a quarter-car file must not, with what a quarter car takes instead
_FULL_VEHICLE_KEYS = {
    "body": "a quarter car has its corner's share of the body: quarter_car.sprung_mass",
    "front": "a quarter car has one corner: its values go in [quarter_car]",
    "rear": "a quarter car has one corner: its values go in [quarter_car]",
    "damper": "a quarter car's damper is [quarter_car.damper]",
    "lca": "a quarter car has no lower control arm",
    f"{QUARTER_CAR_TABLE}.spring_rate": "a quarter car takes wheel_rate (the full file's spring_rate is this rate)",
    f"{QUARTER_CAR_TABLE}.damper_ratio": "a quarter car takes damper_motion_ratio, the damper stroke per unit of "
    "wheel travel (the full file's damper_ratio times the strut's vertical cosine)",
    f"{QUARTER_CAR_TABLE}.strut_direction": "a quarter car is vertical: state damper_motion_ratio instead",
    f"{QUARTER_CAR_TABLE}.strut_top": "a quarter car is vertical: state damper_motion_ratio instead",
}


def check_corner(corner: str) -> str:
    """`corner` if it is one of fl, fr, rl, rr; VehicleModelError otherwise."""
    if corner not in CORNERS:
        raise VehicleModelError(f"corner {corner!r}; expected one of {', '.join(CORNERS)}")
    return corner


@dataclass(frozen=True)
class QuarterCarParameters:
    """Everything a quarter car is built from, in SI units (see the module docstring for the ratios).

    `corner` (fl, fr, rl, rr) is the post the quarter car stands on: its actuator inputs are named after it
    (`actuator_fl_displacement`), so a four-poster drive file feeds it that corner's channels.
    """

    name: str
    description: str
    gravity: float
    corner: str
    sprung_mass: float
    unsprung_mass: float
    wheel_rate: float
    tyre_stiffness: float
    tyre_damping: float
    damper_motion_ratio: float
    damper: DamperParameters
    source: str = "<memory>"

    @classmethod
    def load(cls, path: str | os.PathLike[str] = DEFAULT_FILE, corner: str | None = None) -> "QuarterCarParameters":
        """From a quarter-car file (a `[quarter_car]` table: its own corner, which `corner`, if given, must match) or a
        full-vehicle file (the quarter car of `corner`, default fl, by `from_vehicle`). ParameterError names the
        file and key of a bad value."""
        if corner is not None:
            check_corner(corner)
        data = read_toml(path)
        if QUARTER_CAR_TABLE not in data:
            return cls.from_vehicle(VehicleParameters.load(path), corner or DEFAULT_CORNER)
        params = _read(data, str(path))
        if corner is not None and corner != params.corner:
            raise VehicleModelError(
                f"{path}: this quarter car stands on corner {params.corner!r} ({QUARTER_CAR_TABLE}.corner); "
                f"corner {corner!r} was asked for"
            )
        return params

    @classmethod
    def from_vehicle(cls, params: VehicleParameters, corner: str = DEFAULT_CORNER) -> "QuarterCarParameters":
        """The quarter car of one corner of a full vehicle: the corner's share of the body mass, its axle's wheel rate,
        tyre and damper, and the damper's motion ratio damper_ratio * s_z (the left and right corners are mirror
        images, so fl and fr differ only in the corner they name)."""
        front = check_corner(corner)[0] == "f"
        axle = params.front if front else params.rear
        return cls(
            name=params.name,
            description=f"{corner} corner of {params.description}",
            gravity=params.gravity,
            corner=corner,
            sprung_mass=corner_sprung_mass(params, "front" if front else "rear"),
            unsprung_mass=axle.unsprung_mass,
            wheel_rate=axle.spring_rate,
            tyre_stiffness=axle.tyre_stiffness,
            tyre_damping=axle.tyre_damping,
            damper_motion_ratio=axle.damper_motion_ratio,
            damper=params.front_damper if front else params.rear_damper,
            source=f"{params.source} ({corner} corner)",
        )


def _refuse_full_vehicle_keys(data: dict[str, Any], where: str, source: str) -> None:
    """ParameterError naming the first key of `data` (the table at `where`) that only a full-vehicle file has."""
    for key in data:
        dotted = f"{where}.{key}" if where else key
        if dotted in _FULL_VEHICLE_KEYS:
            raise ParameterError(
                f"{source}: {dotted} belongs to a full-vehicle parameter file, not a quarter-car file "
                f"([{QUARTER_CAR_TABLE}]); {_FULL_VEHICLE_KEYS[dotted]}"
            )


def _read_damper(t: _Table) -> DamperParameters:
    """The damper table: model and linear damping, and the force-velocity table only for model 'spline'."""
    model, damping = t.text("model", DAMPER_MODELS), t.positive("damping")
    if model == "spline":
        velocity, force = read_force_velocity_table(t)
    else:
        table = [t.dotted(key) for key in ("velocity", "force") if t.has(key)]
        if table:
            raise ParameterError(
                f'{t.source}: {", ".join(table)}: a force-velocity table belongs to model = "spline"; this damper '
                f'is "{model}" ({t.dotted("damping")} only)'
            )
        velocity, force = (), ()
    t.finish()
    return DamperParameters(model, damping, velocity, force)


def _read(data: dict[str, Any], source: str) -> QuarterCarParameters:
    """A quarter-car file's tables, checked: ParameterError names the file and key of anything missing or wrong."""
    _refuse_full_vehicle_keys(data, "", source)
    t = _Table(data, "", source)
    q = t.table(QUARTER_CAR_TABLE)
    _refuse_full_vehicle_keys(data[QUARTER_CAR_TABLE], QUARTER_CAR_TABLE, source)
    params = QuarterCarParameters(
        name=t.string("name"),
        description=t.string("description"),
        gravity=t.positive("gravity"),
        corner=q.text("corner", CORNERS),
        sprung_mass=q.positive("sprung_mass"),
        unsprung_mass=q.positive("unsprung_mass"),
        wheel_rate=q.positive("wheel_rate"),
        tyre_stiffness=q.positive("tyre_stiffness"),
        tyre_damping=q.non_negative("tyre_damping"),
        damper_motion_ratio=q.positive("damper_motion_ratio"),
        damper=_read_damper(q.table("damper")),
        source=source,
    )
    q.finish()
    t.finish()
    return params
