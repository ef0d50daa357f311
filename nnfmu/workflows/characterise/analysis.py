"""What a test reads from a sine's position and force: the first harmonic (least squares on sin/cos), a damper's
forces at peak rebound and jounce velocity, its gas force and friction, a bushing's dynamic stiffness and loss angle.

The same functions read the model's clean test cycle and a measured record's noisy cycles (averaged over them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnfmu.workflows.characterise.kind import CharacteriseError

# The slowest test's samples whose speed lies in this band of its peak (above the seal's break-away, below the
# valve's knee) carry the gas force and friction (`gas_and_friction`).
FRICTION_BAND = (0.2, 0.6)


@dataclass(frozen=True)
class Harmonic:
    """y ≈ mean + Im(phasor·exp(iωt)) = mean + a·sin ωt + b·cos ωt with phasor a + ib, fitted by least squares."""

    mean: float
    phasor: complex

    @property
    def amplitude(self) -> float:
        return abs(self.phasor)


def first_harmonic(time: np.ndarray, y: np.ndarray, frequency: float) -> Harmonic:
    """The first harmonic of `y` at `frequency` [Hz] over the samples given (whole cycles read best)."""
    omega = 2 * math.pi * frequency
    basis = np.column_stack([np.ones_like(time), np.sin(omega * time), np.cos(omega * time)])
    (mean, a, b), *_ = np.linalg.lstsq(basis, y, rcond=None)
    return Harmonic(float(mean), complex(a, b))


def _quadratic(time: np.ndarray, y: np.ndarray, instants: np.ndarray) -> np.ndarray:
    """`y` at `instants` by the parabola through the three samples around each (a linear interpolation would cut
    the force's rounded peak by up to (ωT)²/8, 0.3 % at 24 Hz and 1 kHz)."""
    j = np.clip(np.searchsorted(time, instants), 1, len(time) - 2)
    t0, t1, t2 = time[j - 1], time[j], time[j + 1]
    y0, y1, y2 = y[j - 1], y[j], y[j + 1]
    return (
        y0 * (instants - t1) * (instants - t2) / ((t0 - t1) * (t0 - t2))
        + y1 * (instants - t0) * (instants - t2) / ((t1 - t0) * (t1 - t2))
        + y2 * (instants - t0) * (instants - t1) / ((t2 - t0) * (t2 - t1))
    )


@dataclass(frozen=True)
class DamperPoint:
    """One point of the characteristic: the test (peak velocity [m/s], amplitude [m], frequency [Hz], command) and
    the force [N] at peak rebound velocity (positive) and at peak jounce velocity (negative)."""

    peak_velocity: float
    amplitude: float
    frequency: float
    command: float | None
    rebound_force: float
    jounce_force: float


def damper_point(
    time: np.ndarray, position: np.ndarray, force: np.ndarray, frequency: float, command: float | None = None
) -> DamperPoint:
    """The characteristic point of a sine test's cycles: the displacement's first harmonic gives amplitude and phase,
    the force is interpolated (quadratically) at every instant of peak rebound (phase 0 of x = X·sin(ωt + φ)) and
    jounce (phase π) velocity inside the samples and averaged."""
    fit = first_harmonic(time, position, frequency)
    omega = 2 * math.pi * frequency
    phase = math.atan2(fit.phasor.imag, fit.phasor.real)
    forces = []
    for target in (0.0, math.pi):
        first = math.ceil((omega * time[0] + phase - target) / (2 * math.pi))
        last = math.floor((omega * time[-1] + phase - target) / (2 * math.pi))
        instants = (2 * math.pi * np.arange(first, last + 1) + target - phase) / omega
        if instants.size == 0:
            raise CharacteriseError(f"a {frequency:g} Hz test of {time[-1] - time[0]:g} s holds no peak velocity")
        forces.append(float(np.mean(_quadratic(time, force, instants))))
    return DamperPoint(omega * fit.amplitude, fit.amplitude, frequency, command, forces[0], forces[1])


@dataclass(frozen=True)
class GasAndFriction:
    """Gas force [N] (outward push at mid-stroke, positive) and seal friction [N] read from the slowest test."""

    gas_force: float
    friction: float
    peak_velocity: float


def gas_and_friction(time: np.ndarray, position: np.ndarray, force: np.ndarray, frequency: float) -> GasAndFriction:
    """Least squares on the samples moving at FRICTION_BAND of the peak speed: F = a₊[v>0] + a₋[v<0] + b₊v⁺ + b₋v⁻
    + k·x (x and v the fitted sine's, so noise does not select samples). The valve lines through each side's samples
    meet zero speed at a₊ = F_friction − F_gas and a₋ = −F_friction − F_gas; k takes the gas rate and the lag."""
    fit = first_harmonic(time, position, frequency)
    omega = 2 * math.pi * frequency
    x = fit.mean + np.imag(fit.phasor * np.exp(1j * omega * time))
    v = np.imag(1j * omega * fit.phasor * np.exp(1j * omega * time))
    peak = omega * fit.amplitude
    inside = (np.abs(v) >= FRICTION_BAND[0] * peak) & (np.abs(v) <= FRICTION_BAND[1] * peak)
    up, down = inside & (v > 0), inside & (v < 0)
    if up.sum() < 3 or down.sum() < 3:
        raise CharacteriseError(f"the {frequency:g} Hz test has too few samples to read gas force and friction")
    basis = np.column_stack([up, down, np.where(up, v, 0.0), np.where(down, v, 0.0), x - fit.mean])[inside]
    (a_up, a_down, *_), *_ = np.linalg.lstsq(basis.astype(float), force[inside], rcond=None)
    return GasAndFriction(-(a_up + a_down) / 2, (a_up - a_down) / 2, peak)


@dataclass(frozen=True)
class StiffnessPoint:
    """One point of a bushing channel's dynamic stiffness: frequency [Hz], amplitude (m or rad), |K*| (N/m or
    N.m/rad) and loss angle [deg] (the force's lead over the deflection)."""

    channel: str
    frequency: float
    amplitude: float
    dynamic_stiffness: float
    loss_angle: float


def stiffness_point(
    channel: str, time: np.ndarray, position: np.ndarray, force: np.ndarray, frequency: float
) -> StiffnessPoint:
    """K* = F₁/x₁, the ratio of the first-harmonic phasors of force and deflection."""
    x1 = first_harmonic(time, position, frequency)
    if x1.amplitude == 0:
        raise CharacteriseError(f"channel {channel!r}: the {frequency:g} Hz test does not move")
    k = first_harmonic(time, force, frequency).phasor / x1.phasor
    return StiffnessPoint(channel, frequency, x1.amplitude, abs(k), math.degrees(math.atan2(k.imag, k.real)))
