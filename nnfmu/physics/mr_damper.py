"""Truth physics of a magnetorheological (MR) damper: Spencer's phenomenological (modified Bouc–Wen) model.

Spencer, Dyke, Sain and Carlson 1997, "Phenomenological model of a magnetorheological damper" (J. Eng. Mech. 123(3)):
a Bouc–Wen element and a dashpot c0 in parallel, with a spring k0, in series with the internal dashpot c1, and the
accumulator's spring k1 across the whole damper. With w = x - y (the deflection of the Bouc–Wen branch, y the
internal coordinate) and r = ẋ - ẏ:

    ż = -γ|r| z|z|^(n-1) - β r |z|^n + A r                    (evolutionary variable, n = 2)
    ẏ = (α z + c0 ẋ + k0 (x - y)) / (c0 + c1)
    F = c1 ẏ + k1 (x - x0)                                      (tension positive: x0 > 0 is the gas preload)
    α(u) = αa + αb u,  c0(u) = c0a + c0b u,  c1(u) = c1a + c1b u,  u̇ = -η (u - v)

v [V] is the commanded coil voltage, u its first-order lag (coil inductance, field build-up).

Parameter values: Spencer's identified SD-1000 values converted to SI (A, β, γ, n, k0, c1a, η unchanged), with the
voltage-dependent yield and viscous terms rescaled to a passenger-car MR damper commanded over 0-5 V: ~1 kN at
1 m/s and 0 V, ~3.6 kN at 1 m/s and 5 V, yield force (α·z_max) ~0.13-1.9 kN — the range reported for Delphi
MagneRide-type car dampers (force ratio on/off ~3-4 at 1 m/s, ~7 at 0.2 m/s). The accumulator takes the passive
damper's gas values (Dixon: 150-400 N preload, 0.5-2 N/mm).

Integration (`simulate`): z depends on the branch's deflection alone (dz/ds = A - (β + γ sgn(z ds)) z², rate-
independent), so over a step of deflection Δs it has a closed form (tanh / linear / tan); w follows backward Euler,
and the step's relative velocity is the root of one monotone scalar equation (bracketed Newton). Stable and accurate
at the dyno's 0.5 ms internal step although z switches within ~20 µm of deflection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from nnfmu.errors import SettingsError
from nnfmu.physics.effects import DEFAULT_EFFECTS, MR_DAMPER_EFFECTS
from nnfmu.physics.parameters import param

# Voltages [V] the command may span: a lab amplifier's 0-5 V drive of the coil.
MR_VOLTAGE_RANGE = (0.0, 5.0)


@dataclass(frozen=True)
class MRDamperParams:
    """Spencer's modified Bouc–Wen MR damper, scaled to a passenger car (see the module docstring)."""

    alpha_a: float = param(2.0e4, "N/m", "Bouc–Wen stiffness α at 0 V (Spencer: 1.40e4)")
    alpha_b: float = param(5.6e4, "N/(m.V)", "rise of α per volt (Spencer: 6.95e4 over 0-2.25 V; here 0-5 V)")
    c0_a: float = param(1000.0, "N.s/m", "viscous damping c0 at 0 V, above yield (Spencer: 2100)")
    c0_b: float = param(200.0, "N.s/(m.V)", "rise of c0 per volt (Spencer: 350 over 0-2.25 V)")
    c1_a: float = param(2.83e4, "N.s/m", "internal dashpot c1 at 0 V, the low-velocity roll-off (Spencer: 2.83e4)")
    c1_b: float = param(295.0, "N.s/(m.V)", "rise of c1 per volt (Spencer: 295)")
    k0: float = param(4690.0, "N/m", "stiffness k0 controlling the high-velocity stiffness (Spencer: 4690)")
    k1: float = param(1000.0, "N/m", "accumulator stiffness k1 (gas rate, as the passive damper's)")
    x0: float = param(0.25, "m", "accumulator's initial displacement: k1·x0 = 250 N gas preload at mid-stroke")
    gamma: float = param(3.63e6, "1/m^2", "Bouc–Wen γ (Spencer: 363 cm^-2)")
    beta: float = param(3.63e6, "1/m^2", "Bouc–Wen β (Spencer: 363 cm^-2)")
    a_bw: float = param(301.0, "1", "Bouc–Wen A (Spencer: 301); n = 2 (Spencer's value) is fixed")
    eta: float = param(190.0, "1/s", "rate of the coil's first-order lag, 1/η = 5.3 ms (Spencer: 190)")
    moving_mass: float = param(2.0, "kg", "rod, piston and fixture mass between load cell and actuator (1-3 kg)")

    def __post_init__(self) -> None:
        positive = {
            "alpha_a": self.alpha_a,
            "c0_a": self.c0_a,
            "c1_a": self.c1_a,
            "k0": self.k0,
            "a_bw": self.a_bw,
            "eta": self.eta,
        }
        bad = {k: v for k, v in positive.items() if not (math.isfinite(v) and v > 0)}
        bad.update(
            {
                k: v
                for k, v in (
                    ("alpha_b", self.alpha_b),
                    ("c0_b", self.c0_b),
                    ("c1_b", self.c1_b),
                    ("gamma", self.gamma),
                    ("k1", self.k1),
                )
                if not (math.isfinite(v) and v >= 0)
            }
        )
        if not (math.isfinite(self.beta) and self.beta + self.gamma > 0 and self.beta >= -self.gamma):
            bad["beta"] = self.beta
        if bad:
            raise SettingsError(f"MR damper parameters out of range (need positive rates and gains, β + γ > 0): {bad}")

    @property
    def z_max(self) -> float:
        """The evolutionary variable's saturation sqrt(A / (β + γ)) [m]."""
        return math.sqrt(self.a_bw / (self.beta + self.gamma))

    def alpha(self, u):
        return self.alpha_a + self.alpha_b * np.asarray(u)

    def c0(self, u):
        return self.c0_a + self.c0_b * np.asarray(u)

    def c1(self, u):
        return self.c1_a + self.c1_b * np.asarray(u)


def _flow(zeta: float, sigma: float, a: float, c: float) -> float:
    """ζ after σ >= 0 along dζ/dσ = a - c ζ² (closed form; |ζ| < sqrt(a/c) when c > 0)."""
    if c > 0:
        m = math.sqrt(a / c)
        start = math.atanh(min(max(zeta / m, -1.0 + 1e-15), 1.0 - 1e-15))
        return m * math.tanh(math.sqrt(a * c) * sigma + start)
    if c == 0:
        return zeta + a * sigma
    m = math.sqrt(a / -c)
    return m * math.tan(math.sqrt(-a * c) * sigma + math.atan(zeta / m))


def _reach_zero(zeta: float, a: float, c: float) -> float:
    """σ that dζ/dσ = a - c ζ² needs to bring ζ < 0 to 0."""
    if c > 0:
        m = math.sqrt(a / c)
        return -math.atanh(max(zeta / m, -1.0 + 1e-15)) / math.sqrt(a * c)
    if c == 0:
        return -zeta / a
    m = math.sqrt(a / -c)
    return -math.atan(zeta / m) / math.sqrt(-a * c)


@dataclass(frozen=True)
class MRDamperTruth:
    """The MR damper's force from its state, the prescribed motion and the commanded voltage.

    States: `filtered_voltage` u [V], `bouc_wen_deflection` w = x - y [m], `evolutionary_variable` z [m].
    Effects: "command_lag" (u lags v at rate η; off: u = v), "gas_force" (the accumulator k1 (x - x0)), "inertia"
    (the moving mass's m·a in the load cell's reading).
    """

    params: MRDamperParams = field(default_factory=MRDamperParams)
    effects: tuple[str, ...] = DEFAULT_EFFECTS["mr_damper"]

    state_names: ClassVar[tuple[str, ...]] = ("filtered_voltage", "bouc_wen_deflection", "evolutionary_variable")

    def __post_init__(self) -> None:
        unknown = [e for e in self.effects if e not in MR_DAMPER_EFFECTS]
        if unknown:
            raise SettingsError(f"unknown MR damper effect(s) {unknown}; valid: {', '.join(MR_DAMPER_EFFECTS)}")

    def evolve(self, z: float, deflection: float) -> tuple[float, float]:
        """z after the branch deflects by `deflection` [m], and dz/ds there (exact for Bouc–Wen with n = 2)."""
        p = self.params
        direction = 1.0 if deflection >= 0 else -1.0
        zeta, sigma = direction * z, abs(deflection)
        unloading = p.beta - p.gamma
        if zeta < 0:
            to_zero = _reach_zero(zeta, p.a_bw, unloading)
            if sigma < to_zero:
                zeta = _flow(zeta, sigma, p.a_bw, unloading)
                return direction * zeta, p.a_bw - unloading * zeta * zeta
            zeta, sigma = 0.0, sigma - to_zero
        loading = p.beta + p.gamma
        zeta = _flow(zeta, sigma, p.a_bw, loading)
        return direction * zeta, p.a_bw - loading * zeta * zeta

    def step(
        self, state: tuple[float, float, float], h: float, x: float, v: float, command: float
    ) -> tuple[tuple[float, float, float], float]:
        """One step of `h` [s] to displacement x [m], velocity v [m/s] and commanded voltage [V] at its end: the new
        state and the damper force [N] without gas, inertia (see `force`)."""
        p = self.params
        u, w, z = state
        u = command + (u - command) * math.exp(-p.eta * h) if "command_lag" in self.effects else command
        alpha, c0, c1 = float(p.alpha(u)), float(p.c0(u)), float(p.c1(u))
        scale = c0 + c1 + p.k0 * h
        drive = c1 * v - p.k0 * w
        bound = alpha * p.z_max
        low, high = (drive - bound) / scale, (drive + bound) / scale
        rate = min(max(drive / scale, low), high)
        new_z = z
        for _ in range(60):
            new_z, slope = self.evolve(z, h * rate)
            residual = rate * scale - drive + alpha * new_z
            if residual > 0:
                high = rate
            else:
                low = rate
            guess = rate - residual / (scale + alpha * h * slope)
            guess = guess if low < guess < high else 0.5 * (low + high)
            if abs(guess - rate) <= 1e-13 * (abs(rate) + abs(v) + 1e-9):
                rate = guess
                break
            rate = guess
        new_z, _ = self.evolve(z, h * rate)
        return (u, w + h * rate, new_z), c1 * (v - rate)

    def force(self, damper_force, x, a):
        """The load cell's force [N] (tension positive): the damper's own plus the switched-on gas and inertia."""
        total = np.asarray(damper_force, dtype=float)
        if "gas_force" in self.effects:
            total = total + self.params.k1 * (np.asarray(x) - self.params.x0)
        if "inertia" in self.effects:
            total = total + self.params.moving_mass * np.asarray(a)
        return total

    def simulate(
        self, dt: float, x: np.ndarray, v: np.ndarray, a: np.ndarray, command: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Force [N] and states (shape (n, 3)) along a prescribed motion and commanded voltage [V] sampled every
        `dt` [s], starting at rest (u = v[0] when the lag is off, else 0; w = z = 0)."""
        n = len(x)
        states = np.zeros((n, 3))
        own = np.zeros(n)
        state = (0.0 if "command_lag" in self.effects else float(command[0]), 0.0, 0.0)
        state, own[0] = self.step(state, 0.0, float(x[0]), float(v[0]), float(command[0]))
        states[0] = state
        for i in range(1, n):
            state, own[i] = self.step(state, dt, float(x[i]), float(v[i]), float(command[i]))
            states[i] = state
        return self.force(own, x, a), states
