"""Unit table and conversion to SI: which units each physical quantity accepts and how a channel's quantity is known.

A channel's quantity comes from its *base name*: the longest `_`-separated tail of the name that is a known base
(`displacement`, `velocity`, `acceleration`, `force`, `torque`, `rotation`, `angle`, `angular_velocity`,
`angular_acceleration`, `temperature`, `pressure`, `mass`, `time`, `voltage`, `current`), compared
case-insensitively; whatever precedes it is the direction prefix (`axial_`, `conical_`, `front_left_damper_`, ...).
A unit is read as the channel's quantity says: `g` is a gram for a `mass` channel and standard gravity for an
`acceleration` channel, `lb` a pound-mass or a pound-force. A channel whose name has no known base keeps any known
unit and is converted by that unit's own quantity (`supply [bar]` -> Pa, `stroke [mm]` -> m, `gain [-]` -> 1,
`command [mV]` -> V, `valve [%]` -> 1 as a fraction); a unit of several quantities (AMBIGUOUS_UNITS: `g`, `lb`)
is refused there, since nothing tells which is meant. Such a channel with a unit nnfmu does not know either (`coil
[ohm]`, `pump [1/min]`) keeps the unit as declared, so that it never blocks the channels nnfmu needs; only a unit text
that is no unit at all (`[3x]`, `[?]`: UNIT_SYNTAX) is refused.

Unit spellings are case-sensitive (`K` is kelvin, `kN` is kilonewton); before lookup surrounding whitespace is
stripped, spaces around `/` and `^` are dropped, `*`, `·` and other inner spaces become `.` (so `N*m`, `N m`, `N·m`
all read as `N.m`), `²` becomes `^2` and `µ`/`μ` become `u`. SI unit strings: m, m/s, m/s^2, N, N.m, rad, rad/s,
rad/s^2, K, s, Pa, kg, V, A, 1 (the command signals of semi-active dampers come in V or A, valve openings in %).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from nnfmu.data.errors import DataError

G_STANDARD = 9.80665  # m/s^2 per g, by definition
INCH = 0.0254  # m, by definition
FOOT = 0.3048  # m, by definition
POUND_MASS = 0.45359237  # kg, by definition
POUND_FORCE = POUND_MASS * G_STANDARD  # N
ZERO_CELSIUS = 273.15  # K


@dataclass(frozen=True)
class Quantity:
    """A physical quantity: its SI unit and every accepted spelling as `value_si = value * scale + offset`."""

    name: str
    si: str
    units: dict[str, tuple[float, float]]

    def listing(self) -> str:
        return ", ".join(self.units)


def _linear(table: dict[str, float]) -> dict[str, tuple[float, float]]:
    return {spelling: (scale, 0.0) for spelling, scale in table.items()}


QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        Quantity("length", "m", _linear({"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "in": INCH, "ft": FOOT})),
        Quantity("velocity", "m/s", _linear({"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2, "in/s": INCH, "ft/s": FOOT})),
        Quantity(
            "acceleration",
            "m/s^2",
            _linear({"m/s^2": 1.0, "m/s2": 1.0, "mm/s^2": 1e-3, "mm/s2": 1e-3, "in/s^2": INCH, "g": G_STANDARD}),
        ),
        Quantity(
            "force",
            "N",
            _linear(
                {"N": 1.0, "kN": 1e3, "daN": 10.0, "lbf": POUND_FORCE, "lb": POUND_FORCE, "kip": 1e3 * POUND_FORCE}
            ),
        ),
        Quantity(
            "torque",
            "N.m",
            _linear(
                {
                    "N.m": 1.0,
                    "Nm": 1.0,
                    "N-m": 1.0,
                    "kN.m": 1e3,
                    "kNm": 1e3,
                    "kN-m": 1e3,
                    "lbf.in": POUND_FORCE * INCH,
                    "in.lbf": POUND_FORCE * INCH,
                    "lbf-in": POUND_FORCE * INCH,
                    "in-lbf": POUND_FORCE * INCH,
                    "lbf.ft": POUND_FORCE * FOOT,
                    "ft.lbf": POUND_FORCE * FOOT,
                    "lbf-ft": POUND_FORCE * FOOT,
                    "ft-lbf": POUND_FORCE * FOOT,
                }
            ),
        ),
        Quantity("angle", "rad", _linear({"rad": 1.0, "mrad": 1e-3, "deg": math.pi / 180, "°": math.pi / 180})),
        Quantity(
            "angular_velocity",
            "rad/s",
            _linear({"rad/s": 1.0, "deg/s": math.pi / 180, "°/s": math.pi / 180, "rpm": 2 * math.pi / 60}),
        ),
        Quantity(
            "angular_acceleration",
            "rad/s^2",
            _linear({"rad/s^2": 1.0, "rad/s2": 1.0, "deg/s^2": math.pi / 180, "deg/s2": math.pi / 180}),
        ),
        Quantity(
            "temperature",
            "K",
            {
                "K": (1.0, 0.0),
                "degC": (1.0, ZERO_CELSIUS),
                "°C": (1.0, ZERO_CELSIUS),
                "degF": (5 / 9, ZERO_CELSIUS - 32 * 5 / 9),
                "°F": (5 / 9, ZERO_CELSIUS - 32 * 5 / 9),
            },
        ),
        Quantity("time", "s", _linear({"s": 1.0, "ms": 1e-3, "us": 1e-6})),
        Quantity(
            "pressure",
            "Pa",
            _linear({"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5, "mbar": 1e2, "psi": POUND_FORCE / INCH**2}),
        ),
        Quantity("mass", "kg", _linear({"kg": 1.0, "g": 1e-3, "mg": 1e-6, "lbm": POUND_MASS, "lb": POUND_MASS})),
        Quantity("voltage", "V", _linear({"V": 1.0, "mV": 1e-3, "uV": 1e-6, "kV": 1e3})),
        Quantity("current", "A", _linear({"A": 1.0, "mA": 1e-3, "uA": 1e-6})),
        Quantity("dimensionless", "1", _linear({"1": 1.0, "-": 1.0, "%": 1e-2})),
    )
}

# Channel base name -> quantity name.
CHANNEL_BASES: dict[str, str] = {
    "displacement": "length",
    "velocity": "velocity",
    "acceleration": "acceleration",
    "force": "force",
    "torque": "torque",
    "rotation": "angle",
    "angle": "angle",
    "angular_velocity": "angular_velocity",
    "angular_acceleration": "angular_acceleration",
    "temperature": "temperature",
    "pressure": "pressure",
    "mass": "mass",
    "time": "time",
    "voltage": "voltage",
    "current": "current",
}

SI_UNITS: frozenset[str] = frozenset(q.si for q in QUANTITIES.values())


def _owners() -> dict[str, tuple[Quantity, ...]]:
    """Every unit spelling -> the quantities that accept it (two for `g` and `lb`)."""
    owners: dict[str, tuple[Quantity, ...]] = {}
    for quantity in QUANTITIES.values():
        for spelling in quantity.units:
            owners[spelling] = (*owners.get(spelling, ()), quantity)
    return owners


_UNIT_QUANTITIES = _owners()
AMBIGUOUS_UNITS: frozenset[str] = frozenset(s for s, owners in _UNIT_QUANTITIES.items() if len(owners) > 1)

# A unit text: a letter (or %, °, Ω) then letters, digits and the operators . / ^ -, after `normalise_unit`.
UNIT_SYNTAX = re.compile(r"[A-Za-z%°Ω1][A-Za-z0-9%°Ω.^/\-]*")
_AROUND_DIVISION = re.compile(r"\s*([/^])\s*")
_PRODUCT = re.compile(r"\s*[*·]\s*|\s+")


def normalise_unit(unit: str) -> str:
    """The lookup spelling of a unit text (see the module docstring): `' N * m '` -> `'N.m'`, `'m/s²'` -> `'m/s^2'`."""
    text = unit.strip().replace("²", "^2").replace("µ", "u").replace("μ", "u")
    return _PRODUCT.sub(".", _AROUND_DIVISION.sub(r"\1", text))


def kept_unit(unit: str) -> bool:
    """Whether a channel of unknown quantity keeps `unit` as declared: a well-formed unit text nnfmu does not know."""
    spelling = normalise_unit(unit)
    return spelling not in _UNIT_QUANTITIES and UNIT_SYNTAX.fullmatch(spelling) is not None


def unit_quantities(unit: str) -> tuple[Quantity, ...]:
    """The quantities a unit text belongs to: one, two for `g` and `lb`, none for a unit nnfmu does not know."""
    return _UNIT_QUANTITIES.get(normalise_unit(unit), ())


def base_name(channel: str) -> str | None:
    """The known base at the end of a channel name (`'axial_angular_velocity'` -> `'angular_velocity'`), else None."""
    parts = channel.strip().lower().split("_")
    for start in range(len(parts)):
        tail = "_".join(parts[start:])
        if tail in CHANNEL_BASES:
            return tail
    return None


def channel_quantity(channel: str) -> Quantity | None:
    """The quantity a channel measures, known from its base name; None for a channel name nnfmu does not know."""
    base = base_name(channel)
    return None if base is None else QUANTITIES[CHANNEL_BASES[base]]


def si_unit_of(channel: str) -> str | None:
    """The SI unit string a channel must carry in a `Measurement`, or None when its name gives no quantity."""
    quantity = channel_quantity(channel)
    return None if quantity is None else quantity.si


def _all_units() -> str:
    return "; ".join(f"{q.name}: {q.listing()}" for q in QUANTITIES.values())


def _a(quantity: Quantity) -> str:
    """The quantity's name with its article: 'a force', 'an acceleration'."""
    return f"{'an' if quantity.name[0] in 'aeiou' else 'a'} {quantity.name}"


def _quantity_names(quantities: tuple[Quantity, ...]) -> str:
    return " or ".join(_a(q) for q in quantities)


def to_si(values: np.ndarray, unit: str, channel: str, source: str | None = None) -> tuple[np.ndarray, str]:
    """Convert a channel's values from `unit` to SI; return (new float64 array, SI unit string).

    The channel name fixes the quantity (see the module docstring), and the unit must belong to it (`force [m]` is
    an error); a channel with an unknown name is converted by the unit's own quantity, unless the unit belongs to
    several (`mystery [g]`), and keeps a well-formed unit nnfmu does not know as declared (`kept_unit`). `source` (a
    file) prefixes error messages. Raises DataError for an unknown unit of a known quantity, an ambiguous or wrong
    unit, or a unit text that is no unit.
    """
    where = f"{source}: " if source else ""
    spelling = normalise_unit(unit)
    of_unit = _UNIT_QUANTITIES.get(spelling, ())
    quantity = channel_quantity(channel)
    if quantity is None and len(of_unit) > 1:
        raise DataError(
            f"{where}channel {channel!r}: unit {unit!r} is {_quantity_names(of_unit)}, and the name {channel!r} does "
            f"not say which; name the channel after its quantity (e.g. '{channel}_{of_unit[0].name}')"
        )
    quantity = quantity or (of_unit[0] if of_unit else None)
    if quantity is None:
        if kept_unit(unit):
            return np.array(values, dtype=np.float64), spelling
        raise DataError(
            f"{where}channel {channel!r}: {unit!r} is not a unit (a letter, then letters, digits and "
            f". / ^ -); known units are {_all_units()}"
        )
    if spelling not in quantity.units:
        if of_unit:
            raise DataError(
                f"{where}channel {channel!r} is {_a(quantity)} but its unit {unit!r} is {_quantity_names(of_unit)}; "
                f"{quantity.name} units are {quantity.listing()}"
            )
        raise DataError(
            f"{where}channel {channel!r}: unknown {quantity.name} unit {unit!r}; "
            f"{quantity.name} units are {quantity.listing()}"
        )
    scale, offset = quantity.units[spelling]
    converted = np.multiply(np.asarray(values, dtype=np.float64), scale)  # one new array: x * scale + offset
    converted += offset
    return converted, quantity.si
