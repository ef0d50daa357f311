"""Declarative vehicle parameters (masses, inertias, geometry, rates, tyres, dampers, LCA bushings) read from TOML.

Coordinates are the vehicle's (ISO 8855): origin at the sprung mass's centre of gravity in the design position,
x forward, y left, z up, in metres. Geometry of the front suspension is given for the left side; the right side is
its mirror image in y. Every value is SI (kg, m, N/m, N.s/m, N.m/rad, kg.m^2). A quarter-car file (a `[quarter_car]`
table) is read by `quarter_car_parameters` with the same table reader.
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nnfmu.input_files import not_regular
from nnfmu.vehicle.dynamics.errors import ParameterError

DEFAULTS_DIR = Path(__file__).resolve().parent.parent / "parameters"
DEFAULT_FILE = DEFAULTS_DIR / "midsize_sedan.toml"
QUARTER_CAR_TABLE = "quarter_car"  # the table that makes a parameter file a quarter-car file


class _Table:
    """One TOML table being read: typed access by key, errors that name the file and dotted key, unknown keys
    refused."""

    def __init__(self, data: dict[str, Any], where: str, source: str) -> None:
        self._data = data
        self._where = where
        self._source = source
        self._used: set[str] = set()

    @property
    def source(self) -> str:
        """The file being read (what every error message starts with)."""
        return self._source

    def _key(self, key: str) -> str:
        return f"{self._where}.{key}" if self._where else key

    def dotted(self, key: str) -> str:
        """`key`'s full name in the file, such as 'quarter_car.damper.model'."""
        return self._key(key)

    def has(self, key: str) -> bool:
        """Whether the table holds `key` (without marking it read)."""
        return key in self._data

    def _raw(self, key: str) -> Any:
        if key not in self._data:
            raise ParameterError(f"{self._source}: missing key {self._key(key)!r}")
        self._used.add(key)
        return self._data[key]

    def positive(self, key: str) -> float:
        value = self.number(key)
        if value <= 0.0:
            raise ParameterError(f"{self._source}: {self._key(key)} = {value} must be > 0")
        return value

    def non_negative(self, key: str) -> float:
        value = self.number(key)
        if value < 0.0:
            raise ParameterError(f"{self._source}: {self._key(key)} = {value} must be >= 0")
        return value

    def number(self, key: str) -> float:
        value = self._raw(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ParameterError(f"{self._source}: {self._key(key)} = {value!r} is not a finite number")
        return float(value)

    def string(self, key: str) -> str:
        """A text value such as a name (any string)."""
        value = self._raw(key)
        if not isinstance(value, str):
            raise ParameterError(f"{self._source}: {self._key(key)} = {value!r} must be a string")
        return value

    def text(self, key: str, choices: tuple[str, ...]) -> str:
        value = self._raw(key)
        if value not in choices:
            raise ParameterError(f"{self._source}: {self._key(key)} = {value!r}; expected one of {', '.join(choices)}")
        return str(value)

    def vector(self, key: str, size: int = 3) -> tuple[float, ...]:
        value = self._raw(key)
        if not isinstance(value, list) or len(value) != size:
            raise ParameterError(f"{self._source}: {self._key(key)} = {value!r} must be a list of {size} numbers")
        if any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in value):
            raise ParameterError(
                f"{self._source}: {self._key(key)} = {value!r} holds a value that is not a finite number"
            )
        return tuple(float(v) for v in value)

    def numbers(self, key: str) -> tuple[float, ...]:
        value = self._raw(key)
        if not isinstance(value, list) or not value:
            raise ParameterError(f"{self._source}: {self._key(key)} = {value!r} must be a non-empty list of numbers")
        return self.vector(key, len(value))

    def table(self, key: str) -> "_Table":
        value = self._raw(key)
        if not isinstance(value, dict):
            raise ParameterError(f"{self._source}: {self._key(key)} must be a table")
        return _Table(value, self._key(key), self._source)

    def finish(self) -> None:
        """Refuse keys nobody read (a typo would otherwise be ignored silently)."""
        unknown = sorted(set(self._data) - self._used)
        if unknown:
            names = ", ".join(self._key(k) for k in unknown)
            raise ParameterError(f"{self._source}: unknown key(s) {names}")


@dataclass(frozen=True)
class BodyParameters:
    """Sprung mass, its inertias about the centre of gravity, and the wheel layout."""

    mass: float
    roll_inertia: float
    pitch_inertia: float
    cog_to_front_axle: float
    wheelbase: float
    track_front: float
    track_rear: float

    @property
    def cog_to_rear_axle(self) -> float:
        return self.wheelbase - self.cog_to_front_axle


@dataclass(frozen=True)
class AxleParameters:
    """One axle's corners: unsprung mass, spring rate at the wheel, tyre, and the spring/damper line (left side).

    `strut_direction` points from the wheel to the body mount `strut_top`; the spring and damper both act along it,
    so the strut's tilt enters both: for vertical wheel travel the strut deflects `strut_vertical` (s_z, its vertical
    cosine) per unit. The file states the spring by its rate at the wheel (`spring_rate`; the coil along the strut is
    `strut_spring_rate` = spring_rate / s_z^2) and the damper along its own stroke (its dyno characteristic):
    `damper_ratio` is damper stroke per unit strut deflection (1 for a strut, below 1 for a damper on a link), so
    the damper moves `damper_motion_ratio` = damper_ratio * s_z per unit of vertical wheel travel.
    """

    unsprung_mass: float
    spring_rate: float
    tyre_stiffness: float
    tyre_damping: float
    strut_direction: tuple[float, float, float]
    strut_top: tuple[float, float, float]
    damper_ratio: float

    @property
    def strut_unit(self) -> np.ndarray:
        s = np.asarray(self.strut_direction)
        return s / np.linalg.norm(s)

    @property
    def strut_vertical(self) -> float:
        """s_z [1]: strut deflection per unit of vertical wheel travel relative to the body (the strut's cosine)."""
        return float(self.strut_unit[2])

    @property
    def strut_spring_rate(self) -> float:
        """Rate [N/m] of the coil along the strut that gives `spring_rate` at the wheel: spring_rate / s_z^2."""
        return self.spring_rate / self.strut_vertical**2

    @property
    def damper_motion_ratio(self) -> float:
        """Damper stroke per unit of vertical wheel travel relative to the body [1]: damper_ratio * s_z."""
        return self.damper_ratio * self.strut_vertical


DAMPER_MODELS = ("linear", "spline")


@dataclass(frozen=True)
class DamperParameters:
    """A damper's built-in reference along its own stroke: linear damping, or a piecewise-linear force-velocity spline
    (rebound positive); `damping` is also the linear reference of a stabilised damper port."""

    model: str
    damping: float
    velocity: tuple[float, ...]
    force: tuple[float, ...]


@dataclass(frozen=True)
class BushingParameters:
    """One LCA bushing: centre, axis and radial direction (left side), linear reference stiffness and damping.

    The second radial direction and the second conical direction (about the radial direction) have no port; they
    always use the radial and conical reference values (a rotationally symmetric bushing).
    """

    position: tuple[float, float, float]
    axis: tuple[float, float, float]
    radial: tuple[float, float, float]
    axial_stiffness: float
    radial_stiffness: float
    torsional_stiffness: float
    conical_stiffness: float
    axial_damping: float
    radial_damping: float
    torsional_damping: float
    conical_damping: float


@dataclass(frozen=True)
class LcaParameters:
    """Front lower control arm (left side): rigid body with a front and a rear bushing and an outer ball joint."""

    mass: float
    inertia: tuple[float, float, float]
    centre_of_mass: tuple[float, float, float]
    ball_joint: tuple[float, float, float]
    front_bushing: BushingParameters
    rear_bushing: BushingParameters


@dataclass(frozen=True)
class VehicleParameters:
    """Everything the quarter-car and full-vehicle models are built from, in SI units."""

    name: str
    description: str
    gravity: float
    body: BodyParameters
    front: AxleParameters
    rear: AxleParameters
    front_damper: DamperParameters
    rear_damper: DamperParameters
    lca: LcaParameters
    source: str = "<memory>"

    @classmethod
    def load(cls, path: str | os.PathLike[str] = DEFAULT_FILE) -> "VehicleParameters":
        """Read and check a full-vehicle TOML parameter file; any problem raises ParameterError naming the file and
        key (a quarter-car file included: it lacks the body, rear axle and LCA a full vehicle needs)."""
        data = read_toml(path)
        if QUARTER_CAR_TABLE in data:
            raise ParameterError(
                f"{path}: a quarter-car parameter file ([{QUARTER_CAR_TABLE}]); a full vehicle needs a full-vehicle "
                "file (body, front, rear, damper, lca), such as the packaged midsize_sedan.toml"
            )
        return _read(_Table(data, "", str(path)), str(path))


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The tables of a TOML parameter file; ParameterError naming the file when it is missing or not TOML."""
    path = Path(path)
    why = not_regular(path)
    if why:
        raise ParameterError(f"{path}: {why}")
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ParameterError(f"{path}: no such parameter file") from None
    except IsADirectoryError:
        raise ParameterError(f"{path}: a folder, not a parameter file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:  # tomllib recurses once per nested array or table
        raise ParameterError(f"{path}: not valid TOML (arrays or tables nested too deeply)") from None


def corner_sprung_mass(params: VehicleParameters, axle: str) -> float:
    """Share of the body mass [kg] that one corner of `axle` ('front' or 'rear') carries statically: the axle load
    from the centre of gravity's position on the wheelbase, halved."""
    body = params.body
    lever = body.cog_to_rear_axle if axle == "front" else body.cog_to_front_axle
    return body.mass * lever / body.wheelbase / 2.0


def _read_axle(t: _Table) -> AxleParameters:
    axle = AxleParameters(
        unsprung_mass=t.positive("unsprung_mass"),
        spring_rate=t.positive("spring_rate"),
        tyre_stiffness=t.positive("tyre_stiffness"),
        tyre_damping=t.non_negative("tyre_damping"),
        strut_direction=t.vector("strut_direction"),
        strut_top=t.vector("strut_top"),
        damper_ratio=t.positive("damper_ratio"),
    )
    if axle.strut_direction[2] <= 0.1 * float(np.linalg.norm(axle.strut_direction)):
        raise ParameterError(f"{t._source}: {t._key('strut_direction')} = {axle.strut_direction} must point upwards")
    t.finish()
    return axle


def _read_damper(t: _Table) -> DamperParameters:
    damper = DamperParameters(t.text("model", DAMPER_MODELS), t.positive("damping"), *read_force_velocity_table(t))
    t.finish()
    return damper


def read_force_velocity_table(t: _Table) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A damper table's `velocity` and `force` lists: same length (>= 2), velocities strictly increasing."""
    velocity, force = t.numbers("velocity"), t.numbers("force")
    where = f"{t._source}: {t._where}"
    if len(velocity) != len(force) or len(velocity) < 2:
        raise ParameterError(
            f"{where}: velocity and force need the same length (>= 2); got {len(velocity)} and {len(force)}"
        )
    if np.any(np.diff(velocity) <= 0.0):
        raise ParameterError(f"{where}.velocity must increase strictly: {velocity}")
    return velocity, force


def _read_bushing(t: _Table) -> BushingParameters:
    values = {key: t.vector(key) for key in ("position", "axis", "radial")}
    values |= {f"{d}_stiffness": t.positive(f"{d}_stiffness") for d in ("axial", "radial", "torsional", "conical")}
    values |= {f"{d}_damping": t.non_negative(f"{d}_damping") for d in ("axial", "radial", "torsional", "conical")}
    axis, radial = np.asarray(values["axis"]), np.asarray(values["radial"])
    if np.linalg.norm(axis) == 0.0 or np.linalg.norm(np.cross(axis, radial)) < 1e-3 * np.linalg.norm(
        axis
    ) * np.linalg.norm(radial):
        raise ParameterError(
            f"{t._source}: {t._where}: axis {values['axis']} and radial {values['radial']}"
            " must be non-zero and not parallel"
        )
    t.finish()
    return BushingParameters(**values)


def _read_lca(t: _Table) -> LcaParameters:
    lca = LcaParameters(
        mass=t.positive("mass"),
        inertia=t.vector("inertia"),
        centre_of_mass=t.vector("centre_of_mass"),
        ball_joint=t.vector("ball_joint"),
        front_bushing=_read_bushing(t.table("front_bushing")),
        rear_bushing=_read_bushing(t.table("rear_bushing")),
    )
    if min(lca.inertia) <= 0.0:
        raise ParameterError(f"{t._source}: {t._key('inertia')} = {lca.inertia} must be > 0")
    t.finish()
    return lca


def _read(t: _Table, source: str) -> VehicleParameters:
    body_t = t.table("body")
    body = BodyParameters(
        mass=body_t.positive("mass"),
        roll_inertia=body_t.positive("roll_inertia"),
        pitch_inertia=body_t.positive("pitch_inertia"),
        cog_to_front_axle=body_t.positive("cog_to_front_axle"),
        wheelbase=body_t.positive("wheelbase"),
        track_front=body_t.positive("track_front"),
        track_rear=body_t.positive("track_rear"),
    )
    body_t.finish()
    if body.cog_to_front_axle >= body.wheelbase:
        raise ParameterError(
            f"{source}: body.cog_to_front_axle = {body.cog_to_front_axle} must be < body.wheelbase = {body.wheelbase}"
        )
    dampers = t.table("damper")
    params = VehicleParameters(
        name=str(t._raw("name")),
        description=str(t._raw("description")),
        gravity=t.positive("gravity"),
        body=body,
        front=_read_axle(t.table("front")),
        rear=_read_axle(t.table("rear")),
        front_damper=_read_damper(dampers.table("front")),
        rear_damper=_read_damper(dampers.table("rear")),
        lca=_read_lca(t.table("lca")),
        source=source,
    )
    dampers.finish()
    t.finish()
    return params
