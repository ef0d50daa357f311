"""Each test point's deviation over the network's own error, from the tables' inputs: a damper's larger of its rebound
and jounce deviations, a bushing's first-harmonic force deviation (|ΔK*|·a/√2, worked out here with numpy's complex
numbers); no such columns when the network carries no own error."""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.export.own_error import OwnError
from nnfmu.workflows.characterise.analysis import DamperPoint, StiffnessPoint
from nnfmu.workflows.characterise.damper import DamperResult
from nnfmu.workflows.characterise.kind import BushingChannelPorts
from nnfmu.workflows.characterise.measured import MeasuredBushing, MeasuredDamper
from nnfmu.workflows.characterise.tables import characteristic_rows, stiffness_rows

FORCE = OwnError("force", "N", 10.0, 0.01)


def _damper(rebound: float, jounce: float) -> DamperPoint:
    return DamperPoint(0.5, 0.025, 3.18, None, rebound, jounce)


def test_a_damper_point_is_within_when_both_its_deviations_are() -> None:
    model = DamperResult([], [_damper(1000.0, -500.0), _damper(2000.0, -800.0), _damper(3000.0, -900.0)], {})
    measured = MeasuredDamper(
        [_damper(995.0, -508.0), _damper(2012.0, -799.0), _damper(3000.0, -925.0)], [], [], {}, []
    )
    rows = characteristic_rows(model, None, measured, FORCE)
    assert [r["deviation_over_own_error [1]"] for r in rows] == pytest.approx([0.8, 1.2, 2.5])  # the larger of the two
    assert [r["within_own_error"] for r in rows] == ["yes", "no", "no"]
    assert "within_own_error" not in characteristic_rows(model, None, measured)[0]  # none carried: not judged


def test_a_bushing_points_first_harmonic_force_deviation_over_the_own_error() -> None:
    channel = BushingChannelPorts("conical", "conical_rotation", None, "conical_torque", "rad", "N.m")
    model = [StiffnessPoint("conical", 10.0, 0.02, 1000.0, 5.0), StiffnessPoint("conical", 10.0, 0.04, 900.0, 8.0)]
    measured = [StiffnessPoint("conical", 10.0, 0.02, 1010.0, 6.0), StiffnessPoint("conical", 10.0, 0.04, 950.0, 7.0)]
    own = {"conical_torque": OwnError("conical_torque", "N.m", 0.3, 0.01)}
    rows = stiffness_rows([channel], {"conical": model}, MeasuredBushing({"conical": measured}, {}, {}), own)
    for row, m, p in zip(rows, model, measured):
        k = m.dynamic_stiffness * np.exp(1j * np.radians(m.loss_angle))
        k_measured = p.dynamic_stiffness * np.exp(1j * np.radians(p.loss_angle))
        expected = abs(k - k_measured) * p.amplitude / np.sqrt(2)
        assert row["harmonic_force_deviation_rms [N.m]"] == pytest.approx(expected, rel=1e-12)
        assert row["deviation_over_own_error [1]"] == pytest.approx(expected / 0.3, rel=1e-12)
    assert [r["within_own_error"] for r in rows] == ["yes", "no"]  # 0.29 and 1.49 N.m against 0.3 N.m
