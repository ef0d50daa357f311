"""The step study's estimate (`nnfmu.cosim.step_study`) on runs whose error law is known, and a refused step."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nnfmu.cosim.master import CosimError, CosimSettings
from nnfmu.cosim.results import CosimResult
from nnfmu.cosim.ssp import SystemStructure
from nnfmu.cosim.step_study import study_lines, study_step
from nnfmu.data import Measurement

C = 40.0  # the fake run's error coefficient: y_h = sin(2 pi t) + C h^2 cos(2 pi t)
EMPTY = SystemStructure(name="fake", elements=[], connections=[])


def _run(refuse_below: float = 0.0):
    def run(settings: CosimSettings) -> CosimResult:
        h = settings.step
        if h < refuse_below:
            raise CosimError(f"element 'vehicle' samples every {refuse_below:g} s; the step must be a multiple")
        stop = settings.stop_time if settings.stop_time is not None else 1.0
        t = np.arange(round(stop / h) + 1) * h
        y = np.sin(2 * np.pi * t) + C * h**2 * np.cos(2 * np.pi * t)
        return CosimResult(Measurement(t, {"force": y}, {"force": "N"}), len(t) - 1, len(t) - 1, 0, "fake")

    return run


def test_a_second_order_error_is_estimated_exactly() -> None:
    h = 1e-2
    study = study_step(EMPTY, CosimSettings(step=h), _run(), target=1e-3)
    (force,) = study.channels
    t = np.arange(101) * h
    finest = np.sin(2 * np.pi * t) + C * (h / 4) ** 2 * np.cos(2 * np.pi * t)
    expected = C * h**2 * math.sqrt(np.mean(np.cos(2 * np.pi * t) ** 2)) / math.sqrt(np.mean(finest**2))
    assert force.observed and force.order == pytest.approx(2.0, rel=1e-9)
    assert force.nrmse_h == pytest.approx(expected, rel=1e-9)
    assert force.max_step == pytest.approx(h * math.sqrt(1e-3 / expected), rel=1e-9)
    assert study.largest_step() == force.max_step < h  # 0.4 % at h misses 0.1 %


def test_a_refused_step_is_reported_with_the_masters_reason_and_the_order_taken_as_one() -> None:
    h = 1e-2
    study = study_step(EMPTY, CosimSettings(step=h), _run(refuse_below=0.4 * h), target=1e-2)
    assert list(study.runs) == [h, h / 2] and list(study.refused) == [h / 4]
    (force,) = study.channels
    assert not force.observed and force.order == 1.0
    lines = study_lines(study)
    assert all(len(line) <= 80 for line in lines)
    text = "\n".join(lines)
    assert "step 2.5 ms refused by the master: element 'vehicle' samples every" in text
    assert "* order not observed" in text
