"""The thesis's amplitude ratio at 1 Hz is given only where the record's spectrum resolves 1 Hz."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nnfmu.data.measurement import Measurement
from nnfmu.validate import compare
from nnfmu.workflows.roadtest import amplitude_ratio


def _comparison(duration: float):
    t = np.arange(0.0, duration, 1e-3)
    reference = np.sin(2 * np.pi * 1.0 * t) + 0.3 * np.sin(2 * np.pi * 7.0 * t)
    as_measurement = lambda x: Measurement(time=t, channels={"damper_force": x}, units={"damper_force": "N"})  # noqa: E731
    (c,) = compare(as_measurement(1.1 * reference), as_measurement(reference), ["damper_force"])
    return c


def test_amplitude_ratio_needs_a_record_that_resolves_1_hz() -> None:
    assert math.isnan(amplitude_ratio(_comparison(0.3)))  # first PSD line at ~3.3 Hz: not meaningful
    assert amplitude_ratio(_comparison(8.0)) == pytest.approx(1.1, rel=1e-6)
