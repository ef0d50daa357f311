"""Input selection ranks the input that really drives the output first and keeps a small set."""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.data.measurement import Measurement
from nnfmu.models.selection import SelectionSettings, candidate_taps, select_inputs
from nnfmu.models.train import TrainSettings


def synthetic(n: int = 3000, seed: int = 0) -> Measurement:
    """Independent random displacement, velocity and acceleration; the force depends on velocity[k] only."""
    rng = np.random.default_rng(seed)
    x, v, a = rng.uniform(-1, 1, (3, n))
    return Measurement(
        time=np.arange(n) * 1e-3,
        channels={"displacement": x, "velocity": v, "acceleration": a, "force": 800 * np.tanh(2 * v) + 100 * v},
        units={"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"},
        source="synthetic",
    )


def test_candidates_are_the_direction_kinematics_at_three_delays():
    m = synthetic(100)
    assert [(t.channel, t.delays) for t in candidate_taps(m, "force")] == [
        ("displacement", (0, 1, 2)),
        ("velocity", (0, 1, 2)),
        ("acceleration", (0, 1, 2)),
    ]
    with pytest.raises(ValueError, match="axial_displacement"):
        candidate_taps(m, "axial_force")


@pytest.mark.slow
def test_true_input_ranks_first_and_is_chosen():
    settings = SelectionSettings(hidden=3, max_inputs=3, training=TrainSettings(max_epochs=40, restarts=1))
    result = select_inputs(synthetic(), "force", settings)
    assert len(result.ranking) == 9
    assert result.ranking[0][0] == "velocity[k]"
    assert result.ranking[0][1] > 10 * max(score for _, score in result.ranking[1:])
    assert result.chosen == ["velocity[k]"]
    assert result.spec.feature_names == ["velocity[k]"] and len(result.validation_mse) == 3
