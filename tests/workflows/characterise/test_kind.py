"""The one place a damper or bushing is recognised from its component description, and the one-line refusals that
name the file and the port."""

from __future__ import annotations

import pytest

from nnfmu.component import Component, Port
from nnfmu.workflows.characterise.kind import (
    BushingPorts,
    CharacteriseError,
    DamperPorts,
    component_kind,
)


def _component(inputs: list[tuple[str, str]], outputs: list[tuple[str, str]]) -> Component:
    return Component("m", [Port(n, u) for n, u in inputs], [Port(n, u) for n, u in outputs], sample_period=1e-3)


def test_a_passive_and_a_semi_active_damper() -> None:
    assert component_kind(_component([("velocity", "m/s")], [("force", "N")]), "d.onnx") == DamperPorts(
        False, False, None
    )
    semi = component_kind(
        _component([("velocity", "m/s"), ("displacement", "m"), ("current", "A")], [("force", "N")]), "d.onnx"
    )
    assert semi == DamperPorts(True, False, "current") and semi.command_unit == "A"


def test_bushing_channels_with_and_without_their_rate_inputs() -> None:
    found = component_kind(
        _component(
            [("axial_displacement", "m"), ("axial_velocity", "m/s"), ("conical_rotation", "rad")],
            [("axial_force", "N"), ("conical_torque", "N.m")],
        ),
        "b.fmu",
    )
    assert isinstance(found, BushingPorts)
    assert [(c.key, c.rate, c.stiffness_unit) for c in found.channels] == [
        ("axial", "axial_velocity", "N/m"),
        ("conical_rotation", None, "N.m/rad"),
    ]


@pytest.mark.parametrize(
    ("inputs", "outputs", "names"),
    [
        ([("u", "")], [("y", "")], ["x.onnx", "neither a damper", "inputs: u", "outputs: y"]),
        ([("velocity", "m/s"), ("pressure", "Pa")], [("force", "N")], ["x.onnx", "'pressure'"]),
        ([("velocity", "mm/s")], [("force", "N")], ["x.onnx", "'velocity'", "'mm/s'", "'m/s'"]),
        ([("axial_velocity", "m/s")], [("axial_force", "N")], ["x.onnx", "'axial_force'", "'axial_displacement'"]),
        (
            [("axial_displacement", "m"), ("radial_displacement", "m")],
            [("axial_force", "N")],
            ["x.onnx", "'radial_displacement'"],
        ),
    ],
)
def test_what_no_standard_test_fits_is_refused_naming_file_and_port(
    inputs: list[tuple[str, str]], outputs: list[tuple[str, str]], names: list[str]
) -> None:
    with pytest.raises(CharacteriseError) as caught:
        component_kind(_component(inputs, outputs), "x.onnx")
    for name in names:
        assert name in str(caught.value)
