"""Test signals: one sine per test point on the model's sample clock, ramped in, settled, then one measured cycle."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnfmu.errors import SettingsError
from nnfmu.workflows.characterise.settings import MAX_TEST_SAMPLES, MAX_TESTS, MIN_SAMPLES_PER_CYCLE


@dataclass(frozen=True)
class SineTest:
    """One test point: position `amplitude` (m or rad) at `frequency` [Hz], `settle_cycles` before the measured
    cycle; `command` the semi-active damper's command level (None: passive)."""

    amplitude: float
    frequency: float
    settle_cycles: int
    command: float | None = None

    @property
    def peak_rate(self) -> float:
        """Peak velocity (m/s or rad/s) of the steady sine."""
        return 2 * math.pi * self.frequency * self.amplitude

    def samples(self, period: float) -> int:
        """Samples of the whole test at `period` [s]: the settling cycles, then the measured cycle with the sample
        that closes it."""
        return self.settled_samples(period) + self.cycle_samples(period) + 1

    def settled_samples(self, period: float) -> int:
        """The first sample of the measured cycle: the first at or after the settling cycles' end."""
        return math.ceil(self.settle_cycles / (self.frequency * period) - 1e-9)

    def cycle_samples(self, period: float) -> int:
        """Sample steps of the measured (last) cycle at `period` [s]: a whole period or just over it, so the read
        cycle holds both peak velocities whatever the period's fraction of a sample."""
        return math.ceil(1 / (self.frequency * period) - 1e-9)


@dataclass(frozen=True)
class TestMotion:
    """The prescribed motion of one test: time [s], position, rate, acceleration; `measured` the slice of the last
    cycle (with the sample that closes it), which the analysis reads."""

    time: np.ndarray
    position: np.ndarray
    rate: np.ndarray
    acceleration: np.ndarray
    measured: slice


def check_tests(tests: list[SineTest], period: float, what: str) -> None:
    """SettingsError before any test runs when one is not resolved at `period` [s] (fewer than
    MIN_SAMPLES_PER_CYCLE samples a cycle), or there are more than MAX_TESTS tests, or all together exceed
    MAX_TEST_SAMPLES."""
    if len(tests) > MAX_TESTS:
        raise SettingsError(f"{what}: {len(tests)} test points, more than {MAX_TESTS}; test fewer")
    for test in tests:
        if test.cycle_samples(period) < MIN_SAMPLES_PER_CYCLE:
            raise SettingsError(
                f"{what}: {test.frequency:g} Hz leaves {1 / (test.frequency * period):.3g} samples a cycle at the "
                f"model's sample period {period:g} s; at least {MIN_SAMPLES_PER_CYCLE} are needed"
            )
    total = sum(test.samples(period) for test in tests)
    if total > MAX_TEST_SAMPLES:
        raise SettingsError(
            f"{what}: the tests need {total} samples at {period:g} s, more than {MAX_TEST_SAMPLES}; test fewer or "
            "faster points"
        )


def sine_motion(test: SineTest, period: float) -> TestMotion:
    """x = A·w(t)·sin(2πft) from rest, w rising as a raised cosine over the first cycle when the test settles at
    least one cycle (else a sine from its zero crossing); rate and acceleration are exact derivatives."""
    n = test.samples(period)
    t = np.arange(n) * period
    omega = 2 * math.pi * test.frequency
    s, c = np.sin(omega * t), np.cos(omega * t)
    w, dw, ddw = np.ones(n), np.zeros(n), np.zeros(n)
    if test.settle_cycles >= 1:
        ramp = t < 1 / test.frequency
        k = omega / 2  # raised cosine over one period: w = (1 - cos(πft)) / 2
        w[ramp] = 0.5 * (1 - np.cos(k * t[ramp]))
        dw[ramp] = 0.5 * k * np.sin(k * t[ramp])
        ddw[ramp] = 0.5 * k * k * np.cos(k * t[ramp])
    a = test.amplitude
    return TestMotion(
        time=t,
        position=a * w * s,
        rate=a * (dw * s + w * omega * c),
        acceleration=a * (ddw * s + 2 * dw * omega * c - w * omega**2 * s),
        measured=slice(test.settled_samples(period), n),
    )
