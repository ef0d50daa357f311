"""The vehicle loop's bushing candidate: the network's own stiffness read off a replay, one amplitude on all four
channels, and the terms it fixes with."""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.data import Measurement
from nnfmu.workflows.vehicle_loop.attribution import bushing_candidates
from nnfmu.workflows.vehicle_loop.sensitivity import network_stiffness


def _replay(element: str, rates: dict[str, tuple[str, str, float]]) -> Measurement:
    """A replay where each listed output is k x + 30 v + 5 (plus a little noise) of its deflection x."""
    rng = np.random.default_rng(1)
    time = np.arange(2000) * 1e-3
    channels = {}
    for force, (position, rate, k) in rates.items():
        x = 1e-3 * np.sin(2 * np.pi * 3 * time) + 2e-4 * rng.standard_normal(len(time))
        v = np.gradient(x, time)
        channels |= {
            f"{element}_{position}": x,
            f"{element}_{rate}": v,
            f"{element}_{force}": k * x + 30 * v + 5 + 1e-3 * k * 1e-3 * rng.standard_normal(len(time)),
        }
    return Measurement(time, channels, {name: "" for name in channels})


def test_the_own_stiffness_is_the_fitted_rate_and_one_amplitude_scales_every_channel() -> None:
    replay = _replay(
        "bushing_fl_front",
        {
            "axial_force": ("axial_displacement", "axial_velocity", 1.0e6),
            "conical_torque": ("conical_rotation", "conical_angular_velocity", 2865.0),
            "radial_force": ("radial_displacement", "radial_velocity", -5.0),  # no passive spring: left out
        },
    )
    stiffness = network_stiffness(replay, "bushing_fl_front")
    assert set(stiffness) == {"axial_force", "conical_torque"}
    assert stiffness["axial_force"] == pytest.approx(1.0e6, rel=1e-3)
    assert stiffness["conical_torque"] == pytest.approx(2865.0, rel=1e-3)
    (candidate,) = bushing_candidates("bushing_fl_front", stiffness, 0.1)
    assert candidate.key == "bushing_fl_front:stiffness" and candidate.joint_step == 0.1
    assert [(t.output, t.channel, t.unit) for t in candidate.terms] == [
        ("axial_force", "axial_displacement", "m"),
        ("conical_torque", "conical_rotation", "rad"),
    ]
    fitted = candidate.fitted_terms((0.5,))
    assert [t.coefficient for t in fitted] == pytest.approx([0.5e6, 0.5 * 2865.0], rel=1e-3)
    assert bushing_candidates("bushing_fl_rear", network_stiffness(replay, "bushing_fl_rear"), 0.1) == []
