"""Unit conversion to SI against hand-derivable values, and the errors for wrong or unknown units."""

import math

import numpy as np
import pytest

from nnfmu.data import DataError, to_si
from nnfmu.data.units import AMBIGUOUS_UNITS, QUANTITIES, base_name, normalise_unit

LBF = 0.45359237 * 9.80665  # N: one pound mass under standard gravity, both exact by definition


@pytest.mark.parametrize(
    ("channel", "unit", "values", "expected", "si"),
    [
        ("displacement", "in", [1.0, 2.5, -4.0], [0.0254, 0.0635, -0.1016], "m"),
        ("axial_displacement", "mm", [1.0, -250.0], [1e-3, -0.25], "m"),
        ("displacement", "ft", [1.0], [0.3048], "m"),
        ("displacement", "µm", [1.0], [1e-6], "m"),
        ("velocity", "in/s", [10.0], [0.254], "m/s"),
        ("acceleration", "g", [1.0, -2.0], [9.80665, -19.6133], "m/s^2"),
        ("acceleration", "m/s²", [3.0], [3.0], "m/s^2"),
        ("acceleration", "m/s2", [3.0], [3.0], "m/s^2"),
        ("force", "lbf", [1.0, 100.0], [LBF, 100 * LBF], "N"),
        ("force", "kip", [1.0], [1000 * LBF], "N"),
        ("radial_force", "kN", [1.5], [1500.0], "N"),
        ("force", "daN", [2.0], [20.0], "N"),
        ("torque", "N m", [2.0], [2.0], "N.m"),
        ("torque", "N*m", [2.0], [2.0], "N.m"),
        ("torque", "Nm", [2.0], [2.0], "N.m"),
        ("axial_torque", "lbf.ft", [1.0], [LBF * 0.3048], "N.m"),
        ("conical_torque", "lbf.in", [1.0], [LBF * 0.0254], "N.m"),
        ("conical_rotation", "deg", [180.0, 90.0, -45.0], [math.pi, math.pi / 2, -math.pi / 4], "rad"),
        ("rotation", "mrad", [5.0], [5e-3], "rad"),
        ("axial_angular_velocity", "rpm", [60.0], [2 * math.pi], "rad/s"),
        ("angular_velocity", "deg/s", [360.0], [2 * math.pi], "rad/s"),
        ("temperature", "degC", [0.0, 100.0, -40.0], [273.15, 373.15, 233.15], "K"),
        ("temperature", "°C", [20.0], [293.15], "K"),
        ("temperature", "degF", [32.0, 212.0, -40.0], [273.15, 373.15, 233.15], "K"),
        ("time", "ms", [1.0, 2.0], [1e-3, 2e-3], "s"),
        ("gas_pressure", "bar", [2.0], [2e5], "Pa"),
        ("supply", "psi", [1.0], [LBF / 0.0254**2], "Pa"),
        ("stroke", "mm", [3.0], [3e-3], "m"),
        ("mass", "g", [500.0], [0.5], "kg"),
        ("payload_mass", "lb", [1.0], [0.45359237], "kg"),
        ("force", "lb", [1.0], [LBF], "N"),
        ("body_acceleration", "g", [1.0], [9.80665], "m/s^2"),
        ("voltage", "V", [2.5], [2.5], "V"),  # a semi-active damper's command, as an MR-damper record has it
        ("coil_voltage", "mV", [250.0], [0.25], "V"),
        ("valve_current", "mA", [1500.0], [1.5], "A"),
        ("command", "kV", [0.002], [2.0], "V"),  # no base name: the unit's own quantity
        ("valve_opening", "%", [50.0, 100.0], [0.5, 1.0], "1"),
    ],
)
def test_to_si_matches_hand_values(channel, unit, values, expected, si):
    converted, si_unit = to_si(np.array(values), unit, channel)
    assert si_unit == si
    np.testing.assert_allclose(converted, expected, rtol=1e-12, atol=0)


def test_si_values_pass_unchanged_bit_for_bit():
    values = np.array([0.1, -1e-300, 7.123456789012345e5])
    converted, _ = to_si(values, "m", "displacement")
    assert np.array_equal(converted, values)
    assert converted is not values


def test_only_gram_and_pound_belong_to_two_quantities():
    spellings = [s for q in QUANTITIES.values() for s in q.units]
    shared = {s for s in spellings if spellings.count(s) > 1}
    assert shared == AMBIGUOUS_UNITS == {"g", "lb"}
    assert all(spellings.count(s) == 2 for s in shared)


@pytest.mark.parametrize(("unit", "quantities"), [("g", "an acceleration or a mass"), ("lb", "a force or a mass")])
def test_ambiguous_unit_of_unknown_channel_is_refused(unit, quantities):
    with pytest.raises(DataError, match=rf"rig\.csv: channel 'payload': unit '{unit}' is {quantities}, and the name"):
        to_si(np.ones(3), unit, "payload", source="rig.csv")


@pytest.mark.parametrize(
    ("name", "base"),
    [
        ("displacement", "displacement"),
        ("axial_displacement", "displacement"),
        ("conical_angular_velocity", "angular_velocity"),
        ("Axial_Force", "force"),
        ("front_left_damper_velocity", "velocity"),
        ("pressure_gain", None),
    ],
)
def test_base_name(name, base):
    assert base_name(name) == base


def test_normalise_unit_spellings():
    assert normalise_unit(" kN · m ") == "kN.m"
    assert normalise_unit("m / s²") == "m/s^2"


def test_unit_of_another_quantity_names_channel_and_both_quantities():
    with pytest.raises(DataError, match=r"rig\.csv: channel 'force' is a force but its unit 'm' is a length"):
        to_si(np.ones(3), "m", "force", source="rig.csv")


def test_unknown_unit_of_known_channel_lists_its_units():
    with pytest.raises(DataError, match=r"channel 'axial_displacement': unknown length unit 'furlong'.*mm.*in"):
        to_si(np.ones(3), "furlong", "axial_displacement")


def test_an_unknown_unit_of_an_unknown_quantity_is_kept_as_declared():
    values = np.array([1.0, 2.0])
    converted, unit = to_si(values, " 1 / min ", "pump_speed")
    assert unit == "1/min" and np.array_equal(converted, values) and converted is not values
    assert to_si(values, "ohm", "coil")[1] == "ohm"


def test_a_unit_text_that_is_no_unit_is_refused_listing_the_known_units():
    with pytest.raises(DataError, match=r"channel 'mystery': '3x' is not a unit .*; known units are length: m"):
        to_si(np.ones(3), "3x", "mystery")


def test_units_are_case_sensitive():
    with pytest.raises(DataError, match="unknown force unit 'kn'"):
        to_si(np.ones(1), "kn", "force")


def test_a_voltage_channel_refuses_a_current_unit():
    with pytest.raises(DataError, match=r"channel 'coil_voltage' is a voltage but its unit 'mA' is a current"):
        to_si(np.array([1.0]), "mA", "coil_voltage")
