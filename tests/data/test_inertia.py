"""Fixture inertia compensation against the dyno simulator run twice on the same stroke: with the moving mass
(what the load cell feels) and without it (the damper alone)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nnfmu.data import DataError, Measurement
from nnfmu.data.inertia import compensate_inertia
from nnfmu.data.rigs import DamperParams, RigOptions, simulate_rig

EFFECTS = ("hysteresis", "seal_friction")


def run(effects: tuple[str, ...], noise: float) -> Measurement:
    return simulate_rig(
        "damper", RigOptions(duration=20.0, seed=3, noise=noise, effects=effects, excitation="random")
    ).measurement


def nrmse(x: np.ndarray, reference: np.ndarray) -> float:
    return float(np.sqrt(np.mean((x - reference) ** 2)) / np.sqrt(np.mean(reference**2)))


@pytest.mark.parametrize("noise", [0.0, 1.0])
def test_compensated_force_is_the_damper_alone(noise: float) -> None:
    with_mass, alone = run((*EFFECTS, "inertia"), noise), run(EFFECTS, 0.0)
    mass = DamperParams().moving_mass
    compensated = compensate_inertia(with_mass, mass)
    before, after = nrmse(with_mass["force"], alone["force"]), nrmse(compensated["force"], alone["force"])
    assert before > 0.01  # the mass is a visible share of the force on this stroke
    assert after < (0.002 if noise == 0.0 else before / 3), (before, after)
    assert "2 kg of moving mass" in compensated.notes["inertia"] and "velocity" in compensated.notes["inertia"]
    assert np.array_equal(compensated["velocity"], with_mass["velocity"])


def test_acceleration_from_displacement_when_velocity_is_missing() -> None:
    with_mass, alone = run((*EFFECTS, "inertia"), 0.0), run(EFFECTS, 0.0)
    stroke_only = replace(
        with_mass,
        channels={k: with_mass[k] for k in ("displacement", "force")},
        units={k: with_mass.units[k] for k in ("displacement", "force")},
    )
    compensated = compensate_inertia(stroke_only, DamperParams().moving_mass)
    assert nrmse(compensated["force"], alone["force"]) < 0.002
    assert "displacement" in compensated.notes["inertia"]


def test_bad_requests_name_the_problem() -> None:
    m = run(EFFECTS, 0.0)
    with pytest.raises(DataError, match="moving mass -1.0 must be a finite number of kg"):
        compensate_inertia(m, -1.0)
    with pytest.raises(DataError, match="no channel 'load'"):
        compensate_inertia(m, 2.0, force="load")
    with pytest.raises(DataError, match="is in m, not N"):
        compensate_inertia(m, 2.0, force="displacement")
    force_only = replace(m, channels={"force": m["force"]}, units={"force": "N"})
    with pytest.raises(DataError, match="needs an acceleration"):
        compensate_inertia(force_only, 2.0)
