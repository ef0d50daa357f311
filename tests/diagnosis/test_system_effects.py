"""The vehicle loop's effects come from the diagnosis registry: each kind's candidate effects are registered system
effects, their terms on a component's network are the ones the loop probes, and the component diagnosis's library is
unchanged by them."""

from __future__ import annotations

import pytest

from nnfmu.diagnosis import EFFECTS, SYSTEM_EFFECTS, Term
from nnfmu.kinds import BUSHING, DAMPER, KINDS


def test_every_kind_names_only_registered_system_effects() -> None:
    assert list(SYSTEM_EFFECTS) == ["gas_force", "stiffness", "sensor_offset"]
    for kind in KINDS.values():
        assert set(kind.loop_effects) <= set(SYSTEM_EFFECTS), kind.name
        assert not any(SYSTEM_EFFECTS[name].on_channel for name in kind.loop_effects), kind.name


def test_the_gas_force_is_a_preload_and_a_rate_on_the_stroke() -> None:
    effect = SYSTEM_EFFECTS["gas_force"]
    assert not effect.joint and not effect.scaled_by_stiffness
    assert effect.terms(DAMPER.channels, {}) == (
        Term("force", None, -100.0, "N"),
        Term("force", "displacement", 2000.0, "m"),
    )


def test_the_stiffness_scales_each_known_channel_by_its_own_stiffness() -> None:
    effect = SYSTEM_EFFECTS["stiffness"]
    assert effect.joint and effect.scaled_by_stiffness and effect.untestable
    terms = effect.terms(BUSHING.channels, {"conical_torque": 2865.0, "axial_force": 1.0e6})
    assert terms == (  # in the kind's channel order, whatever the order of the rates
        Term("axial_force", "axial_displacement", 1.0e6, "m"),
        Term("conical_torque", "conical_rotation", 2865.0, "rad"),
    )
    assert effect.terms(BUSHING.channels, {}) == ()


def test_a_sensor_offset_is_a_channel_s_own_error_and_the_component_library_is_unchanged() -> None:
    offset = SYSTEM_EFFECTS["sensor_offset"]
    assert offset.on_channel and offset.terms(DAMPER.channels, {}) == ()
    assert "stiffness" not in EFFECTS  # a system effect only: the component diagnosis's family count is unchanged
    assert EFFECTS["gas_force"].name == SYSTEM_EFFECTS["gas_force"].name


@pytest.mark.parametrize("name", ["gas_force", "sensor_offset"])
def test_an_effect_with_both_halves_is_one_class_in_both_registries(name: str) -> None:
    assert type(EFFECTS[name]) is type(SYSTEM_EFFECTS[name])
