"""Units of FMU variables and the conversions between them (`nnfmu.cosim.units`), without FMUs."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from nnfmu.cosim.units import PortUnit, UnitError, input_conversion, port_unit, table_unit


def _variable(name: str, unit: str | None = None, declared: str | None = None) -> SimpleNamespace:
    return SimpleNamespace(name=name, unit=unit, declaredType=SimpleNamespace(unit=declared) if declared else None)


def _definition(name: str, factor: float = 1.0, offset: float = 0.0, **exponents: int) -> SimpleNamespace:
    base = {"kg": 0, "m": 0, "s": 0, "A": 0, "K": 0, "mol": 0, "cd": 0, "rad": 0} | exponents
    return SimpleNamespace(name=name, baseUnit=SimpleNamespace(factor=factor, offset=offset, **base))


def test_units_resolve_by_the_fmus_definitions_then_by_the_table() -> None:
    own = [
        _definition("mm", 1e-3, m=1),
        _definition("N.mm", 1e-3, kg=1, m=2, s=-2),
        _definition("furlong", 201.168, m=1),
    ]
    assert port_unit(_variable("z", "mm"), own) == PortUnit("mm", "m", 1e-3, 0.0)
    assert port_unit(_variable("torque", "N.mm"), own) == PortUnit("N.mm", "N.m", 1e-3, 0.0)
    assert port_unit(_variable("len", "furlong"), own).si == "m"
    assert port_unit(_variable("k", "kN/m"), [_definition("kN/m", 1e3, kg=1, s=-2)]) == PortUnit("kN/m", "N/m", 1e3)
    assert port_unit(_variable("q", "J/K"), [_definition("J/K", kg=1, m=2, s=-2, K=-1)]).si == "kg.m^2/s^2.K"
    assert port_unit(_variable("a", declared="m/s2")) == PortUnit("m/s2", "m/s^2", 1.0, 0.0)
    assert port_unit(_variable("f", "kN")) == PortUnit("kN", "N", 1e3, 0.0)
    assert port_unit(_variable("w", "deg")).si == "rad"
    assert port_unit(_variable("t", "degC")) == PortUnit("degC", "K", 1.0, 273.15)
    assert port_unit(_variable("rate", "1/s")) == PortUnit("1/s")  # kept as declared
    assert port_unit(_variable("x")) == PortUnit("")
    assert table_unit("g", "a_body").si is None  # a gram or standard gravity: the name does not say
    assert table_unit("g", "body_acceleration") == PortUnit("g", "m/s^2", 9.80665, 0.0)


def test_connections_convert_within_a_quantity_and_refuse_across() -> None:
    mm, m, kn, n = table_unit("mm"), table_unit("m"), table_unit("kN"), table_unit("N")
    assert input_conversion(mm, m, "c") == (1.0, 0.0)  # the row holds the output in metres
    assert input_conversion(m, mm, "c") == (1000.0, 0.0)
    assert input_conversion(kn, n, "c") == (1.0, 0.0)
    assert input_conversion(table_unit("K"), table_unit("degC"), "c") == (1.0, -273.15)
    assert input_conversion(PortUnit(""), mm, "c") == (1.0, 0.0)  # no unit: passed as it is
    a, b = input_conversion(mm, PortUnit(""), "c")  # into no unit: the output's own millimetres
    assert a == pytest.approx(1000.0) and b == 0.0
    assert input_conversion(PortUnit("1/s"), PortUnit("1/s"), "c") == (1.0, 0.0)
    with pytest.raises(UnitError, match=r"^c: the output is in 'N', the input in 'm'; different quantities"):
        input_conversion(n, m, "c")
    with pytest.raises(UnitError, match=r"the input in 'furlong', and nnfmu knows no conversion of 'furlong'"):
        input_conversion(m, PortUnit("furlong"), "c")


def test_outputs_are_recorded_in_si_where_they_convert_and_never_refused_for_a_missing_unit() -> None:
    from nnfmu.cosim.master import result_unit

    assert result_unit(table_unit("lbf"), "pull") == "N"
    assert result_unit(table_unit("m/s2"), "body_acceleration") == "m/s^2"
    assert result_unit(PortUnit(""), "body_acceleration") == "m/s^2"  # named after its quantity: SI assumed
    assert result_unit(PortUnit(""), "a_spindle") == "1"
    assert result_unit(PortUnit("1/s"), "rate") == "1/s"  # unknown to nnfmu: as declared
