"""Units of FMU variables and the conversions the master applies between them, decided before a run.

A variable's unit is its `unit` attribute, else its declared type's (FMI 2 `declaredType`, FMI 3 the type
definition). It converts to SI by the FMU's own `UnitDefinitions` (a `BaseUnit` with exponents, factor and
offset: SI value = factor * value + offset), else by nnfmu's unit table (`nnfmu.data.units`: the common spellings
`m/s2`, `N.m`, `kN`, `mm`, `deg`, `rad/s`, `lbf`, ...; `g` and `lb` only where the variable's name says the
quantity). A unit neither knows stays as declared.

The master keeps every coupling value in its *row unit*: SI where the output's unit converts, else as the FMU gives
it. Every input takes its value from the row (or the drive, in SI) through a scale and offset to its own unit:
- both ends convert to the same SI unit: converted (`mm` -> `m`, `kN` -> `N`, `degC` -> `K`);
- one end without a unit: passed as the other end has it (FMI: no unit declared is no unit known);
- the same spelling at both ends: passed as it is, known or not;
- anything else (`N` into `m`, `m` into `furlong`): refused before the run, naming element, port and units.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from nnfmu.data.units import QUANTITIES, channel_quantity, normalise_unit, unit_quantities
from nnfmu.errors import NnfmuError

BASE_SYMBOLS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
# SI unit strings nnfmu writes, by base-unit exponents (kg, m, s, A, K, mol, cd, rad)
_NAMED: dict[tuple[int, ...], str] = {
    (0, 1, 0, 0, 0, 0, 0, 0): "m",
    (0, 1, -1, 0, 0, 0, 0, 0): "m/s",
    (0, 1, -2, 0, 0, 0, 0, 0): "m/s^2",
    (1, 1, -2, 0, 0, 0, 0, 0): "N",
    (1, 2, -2, 0, 0, 0, 0, 0): "N.m",
    (0, 0, 0, 0, 0, 0, 0, 1): "rad",
    (0, 0, -1, 0, 0, 0, 0, 1): "rad/s",
    (0, 0, -2, 0, 0, 0, 0, 1): "rad/s^2",
    (0, 0, 0, 0, 1, 0, 0, 0): "K",
    (0, 0, 1, 0, 0, 0, 0, 0): "s",
    (1, -1, -2, 0, 0, 0, 0, 0): "Pa",
    (1, 0, 0, 0, 0, 0, 0, 0): "kg",
    (1, 2, -3, -1, 0, 0, 0, 0): "V",
    (0, 0, 0, 1, 0, 0, 0, 0): "A",
    (0, 0, 0, 0, 0, 0, 0, 0): "1",
    (1, 0, -2, 0, 0, 0, 0, 0): "N/m",
    (1, 0, -1, 0, 0, 0, 0, 0): "N.s/m",
    (0, 0, -1, 0, 0, 0, 0, 0): "1/s",
}


class UnitError(NnfmuError, ValueError):
    """A connection or drive input joins units no conversion links; the message names element, port and units."""


@dataclass(frozen=True)
class PortUnit:
    """A variable's unit as declared (`text`, '' for none) and, when known, its SI unit with value_si = value *
    scale + offset."""

    text: str
    si: str | None = None
    scale: float = 1.0
    offset: float = 0.0

    @property
    def row_unit(self) -> str:
        """The unit its values are kept in by the master: SI when known, else as declared ('' for none)."""
        return self.si if self.si is not None else self.text

    @property
    def converts(self) -> bool:
        """Whether the master changes its values on the way to the row (a unit that is not already SI)."""
        return self.si is not None and (self.scale != 1.0 or self.offset != 0.0)

    def describe(self) -> str:
        """The unit for a message: `'kN' (SI: N)`, `'m'`, `no unit`."""
        if not self.text:
            return "no unit"
        known = self.si is not None and normalise_unit(self.text) != self.si
        return f"{self.text!r} (SI: {self.si})" if known else repr(self.text)


def _si_of_base(exponents: tuple[int, ...]) -> str:
    """The SI unit string of base-unit exponents: nnfmu's spelling where it has one, else a product of powers."""
    if exponents in _NAMED:
        return _NAMED[exponents]
    up = [f"{s}^{e}" if e != 1 else s for s, e in zip(BASE_SYMBOLS, exponents) if e > 0]
    down = [f"{s}^{-e}" if e != -1 else s for s, e in zip(BASE_SYMBOLS, exponents) if e < 0]
    return (".".join(up) or "1") + ("/" + ".".join(down) if down else "")


def declared_unit(variable: object) -> str:
    """A model variable's unit text (fmpy's ModelVariable): its own, else its declared type's, else ''."""
    declared = getattr(variable, "declaredType", None)
    return getattr(variable, "unit", None) or (declared.unit if declared is not None else None) or ""


def port_unit(variable: object, definitions: Iterable[object] = ()) -> PortUnit:
    """The unit of fmpy model variable `variable`, resolved by the FMU's unit `definitions` (fmpy `Unit`s) first,
    then by nnfmu's unit table (the variable's name choosing between the quantities of `g` or `lb`)."""
    text = declared_unit(variable)
    if not text:
        return PortUnit("")
    for unit in definitions:
        base = getattr(unit, "baseUnit", None)
        if getattr(unit, "name", None) == text and base is not None:
            exponents = tuple(int(getattr(base, s)) for s in BASE_SYMBOLS)
            return PortUnit(text, _si_of_base(exponents), float(base.factor), float(base.offset))
    return table_unit(text, getattr(variable, "name", ""))


def table_unit(text: str, name: str = "") -> PortUnit:
    """A unit text resolved by nnfmu's unit table alone (a drive channel's unit, a unit the FMU does not define)."""
    if not text:
        return PortUnit("")
    spelling = normalise_unit(text)
    owners = unit_quantities(text)
    if len(owners) > 1:
        named = channel_quantity(name)
        owners = tuple(q for q in owners if named is not None and q.name == named.name)
    if len(owners) != 1:
        return PortUnit(text)
    quantity = QUANTITIES[owners[0].name]
    scale, offset = quantity.units[spelling]
    return PortUnit(text, quantity.si, scale, offset)


def input_conversion(
    source: PortUnit, target: PortUnit, where: str, source_word: str = "the output"
) -> tuple[float, float]:
    """(a, b) with target value = a * row value + b, where the row holds the source's values in its row unit
    (see the module docstring); UnitError naming `where` (the connection or input) when none exists."""
    if source.si is not None and target.si is not None:
        if source.si != target.si:
            raise UnitError(
                f"{where}: {source_word} is in {source.describe()}, the input in {target.describe()}; different "
                "quantities, which no conversion joins"
            )
        return 1.0 / target.scale, -target.offset / target.scale
    same = source.text and target.text and normalise_unit(source.text) == normalise_unit(target.text)
    if not target.text or same:  # no unit to convert to, or the very unit: the source's own values
        return (1.0 / source.scale, -source.offset / source.scale) if source.si is not None else (1.0, 0.0)
    if not source.text:
        return 1.0, 0.0
    unknown = target if target.si is None else source
    raise UnitError(
        f"{where}: {source_word} is in {source.describe()}, the input in {target.describe()}, and nnfmu knows no "
        f"conversion of {unknown.describe()} (neither the FMU's UnitDefinitions nor nnfmu's unit table define it)"
    )
