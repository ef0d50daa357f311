"""The report's headline of a deviation column: the largest magnitude with its sign and unit, and the test point."""

from __future__ import annotations

from nnfmu.workflows.characterise.tables import largest_deviation


def test_the_largest_deviation_names_its_value_unit_and_test_point() -> None:
    rows = [
        {"channel": "axial", "frequency [Hz]": 1.0, "amplitude [m]": 0.0025, "stiffness_deviation [%]": 4.0},
        {"channel": "axial", "frequency [Hz]": 20.0, "amplitude [m]": 0.0025, "stiffness_deviation [%]": -13.69},
        {"channel": "conical_rotation", "frequency [Hz]": 5.0, "amplitude [rad]": 0.04, "stiffness_deviation [%]": 9.0},
    ]
    where = ("channel", "frequency [Hz]", "amplitude [m]", "amplitude [rad]")
    assert largest_deviation(rows, "stiffness_deviation [%]", where) == (
        "stiffness deviation -13.7 % at axial, 20 Hz, 0.0025 m"
    )
    rows[2]["stiffness_deviation [%]"] = 20.0
    assert largest_deviation(rows, "stiffness_deviation [%]", where) == (
        "stiffness deviation +20 % at conical_rotation, 5 Hz, 0.04 rad"
    )
    assert largest_deviation(rows, "loss_angle_deviation [deg]", where) is None  # no measurement: no headline
