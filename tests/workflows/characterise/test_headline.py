"""The report's headlines: a deviation column's largest magnitude with its sign, unit and test point; a test point
beyond the network's training envelope named with the input, its peak and the envelope, or with its frequency and the
band the training record excited."""

from __future__ import annotations

import pytest

from nnfmu.component import Component, Port
from nnfmu.export import ExportError
from nnfmu.workflows.characterise.envelope import INSIDE, envelope_note
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


def test_a_test_point_beyond_the_training_envelope_is_named() -> None:
    component = Component(
        "bushing",
        [Port("axial_displacement", "m", min=-0.003, max=0.003), Port("axial_velocity", "m/s", min=-0.15, max=0.13)],
        [Port("axial_force", "N")],
    )
    assert envelope_note(component, {"axial_displacement": 0.0025, "axial_velocity": 0.1}) == INSIDE
    assert envelope_note(component, {"axial_displacement": 0.0025, "axial_velocity": 0.14}) == (
        "outside: axial_velocity ±0.14 beyond [-0.15, 0.13] m/s"
    )
    both = envelope_note(component, {"axial_displacement": 0.004, "axial_velocity": 0.2})
    assert both.startswith("outside: axial_displacement ±0.004 beyond [-0.003, 0.003] m; axial_velocity ±0.2")
    assert envelope_note(Component("free", [Port("axial_velocity", "m/s")], []), {"axial_velocity": 9.0}) == INSIDE


def _banded(edges: object) -> Component:
    """An axial bushing component carrying `edges` as its inputs' training band."""
    return Component(
        "bushing",
        [Port("axial_displacement", "m", min=-0.003, max=0.003), Port("axial_velocity", "m/s", min=-0.4, max=0.4)],
        [Port("axial_force", "N")],
        metadata={"training_band": {"power_share": 0.99, "upper_edge_Hz": edges}},
    )


def test_a_test_point_above_the_training_band_is_named_with_the_widest_driven_input() -> None:
    component = _banded({"axial_displacement": 26.75, "axial_velocity": 39.5})
    peaks = {"axial_displacement": 0.000625, "axial_velocity": 0.2}
    assert envelope_note(component, peaks, 39.5) == INSIDE
    assert envelope_note(component, peaks, 50.0) == "outside: 50 Hz above the training band (39.5 Hz, axial_velocity)"
    assert envelope_note(component, peaks) == INSIDE  # no frequency given: the range alone
    # the band of an input the test does not drive says nothing about it
    assert envelope_note(component, {"axial_displacement": 0.000625}, 30.0).endswith("(26.8 Hz, axial_displacement)")
    both = envelope_note(component, {"axial_displacement": 0.0025, "axial_velocity": 0.785}, 50.0)
    assert both == (
        "outside: axial_velocity ±0.785 beyond [-0.4, 0.4] m/s; 50 Hz above the training band (39.5 Hz, axial_velocity)"
    )


@pytest.mark.parametrize(
    "edges", [{"axial_velocity": -1.0}, {"axial_velocity": "40"}, {"axial_velocity": True}, [40.0]]
)
def test_a_malformed_training_band_is_refused_naming_it(edges: object) -> None:
    with pytest.raises(ExportError, match="bushing"):
        envelope_note(_banded(edges), {"axial_velocity": 0.2}, 10.0)
