"""Truth physics of a continuously controlled (CDC) damper: a proportional valve blends a soft and a hard curve.

The valve current i [A] sets the spool's target opening; the spool follows with a first-order lag of `valve_time`.
The force blends two digressive characteristics of the passive damper's kind (`ValveSide`, rebound and jounce):

    h* = clip((i - i_soft) / (i_hard - i_soft), 0, 1),   τ ḣ = h* - h,   F_valve = (1 - h) F_soft(v) + h F_hard(v)

Range and direction: production CDC valves (ZF Sachs CDC, Tenneco CVSA) are driven with ~0.3-1.8 A and settle in
~5-20 ms (supplier data sheets; Savaresi et al. 2010, *Semi-Active Suspension Control Design for Vehicles*, ch. 2).
Which end is hard differs between makes (some fail safe to hard at zero current); here more current is harder.
The soft and hard curves span a factor ~3 at 1 m/s (soft ~1.3 kN / 0.6 kN, hard ~3.8 kN / 1.6 kN rebound / jounce),
around the passive damper's ~2.8 kN / 1.1 kN. Gas force, seal friction and moving mass as for the passive damper.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from nnfmu.errors import SettingsError
from nnfmu.physics.damper import ValveSide
from nnfmu.physics.effects import CDC_DAMPER_EFFECTS, DEFAULT_EFFECTS
from nnfmu.physics.parameters import param

# Currents [A] the command may span: the valve's working range (below it the valve is at its soft end).
CDC_CURRENT_RANGE = (0.3, 1.8)


@dataclass(frozen=True)
class CDCDamperParams:
    """A CDC damper: soft and hard valve curves, the current range between them, the valve lag, gas, seal, mass."""

    soft_rebound: ValveSide = ValveSide(c_low=4000.0, c_high=800.0, knee_velocity=0.15, rounding=100.0)
    soft_jounce: ValveSide = ValveSide(c_low=1500.0, c_high=350.0, knee_velocity=0.20, rounding=60.0)
    hard_rebound: ValveSide = ValveSide(c_low=14000.0, c_high=2000.0, knee_velocity=0.15, rounding=250.0)
    hard_jounce: ValveSide = ValveSide(c_low=5000.0, c_high=800.0, knee_velocity=0.20, rounding=120.0)
    current_soft: float = param(CDC_CURRENT_RANGE[0], "A", "valve current of the soft curve (and below)")
    current_hard: float = param(CDC_CURRENT_RANGE[1], "A", "valve current of the hard curve (and above)")
    valve_time: float = param(0.006, "s", "time constant of the spool's first-order lag (5-20 ms, data sheets)")
    gas_preload: float = param(250.0, "N", "gas force at mid-stroke, pushing the rod out (150-400 N, Dixon)")
    gas_rate: float = param(1000.0, "N/m", "rise of the gas force per m of compression (0.5-2 N/mm)")
    seal_friction: float = param(50.0, "N", "Coulomb level of rod seal and guide friction (30-80 N, Dixon)")
    friction_velocity: float = param(0.002, "m/s", "velocity scale of the tanh-smoothed Coulomb friction")
    moving_mass: float = param(2.0, "kg", "rod, piston and fixture mass between load cell and actuator (1-3 kg)")

    def __post_init__(self) -> None:
        if not (self.current_hard > self.current_soft and self.valve_time > 0 and math.isfinite(self.valve_time)):
            raise SettingsError(f"a CDC damper needs current_hard > current_soft and valve_time > 0; got {self}")


@dataclass(frozen=True)
class CDCDamperTruth:
    """The CDC damper's force from the prescribed motion and valve current; vectorised (one linear state, h).

    Effects: "valve_lag" (the spool's first-order lag; off: h = h*), "gas_force", "seal_friction", "inertia".
    """

    params: CDCDamperParams = field(default_factory=CDCDamperParams)
    effects: tuple[str, ...] = DEFAULT_EFFECTS["cdc_damper"]

    def __post_init__(self) -> None:
        unknown = [e for e in self.effects if e not in CDC_DAMPER_EFFECTS]
        if unknown:
            raise SettingsError(f"unknown CDC damper effect(s) {unknown}; valid: {', '.join(CDC_DAMPER_EFFECTS)}")

    def target_hardness(self, current):
        """The spool's target opening h* in [0, 1] (0 soft, 1 hard) for valve current(s) [A]."""
        p = self.params
        return np.clip((np.asarray(current, dtype=float) - p.current_soft) / (p.current_hard - p.current_soft), 0, 1)

    def hardness(self, dt: float, current: np.ndarray) -> np.ndarray:
        """The spool's opening along a current sampled every `dt` [s], held over each step, from rest at the first
        sample's target (the exact discretisation of the first-order lag)."""
        target = self.target_hardness(current)
        if "valve_lag" not in self.effects:
            return target
        decay = math.exp(-dt / self.params.valve_time)
        out, _ = lfilter([1 - decay], [1.0, -decay], target, zi=[decay * target[0]])
        return out

    def curve(self, v, rebound: ValveSide, jounce: ValveSide):
        v = np.asarray(v, dtype=float)
        return np.where(v >= 0, rebound.force(np.maximum(v, 0)), -jounce.force(np.maximum(-v, 0)))

    def valve_force(self, v, hardness):
        """Valve force [N] at velocity v [m/s] and opening `hardness` in [0, 1]: the soft and hard curves blended."""
        p = self.params
        soft = self.curve(v, p.soft_rebound, p.soft_jounce)
        hard = self.curve(v, p.hard_rebound, p.hard_jounce)
        h = np.asarray(hardness, dtype=float)
        return (1 - h) * soft + h * hard

    def force(self, x, v, a, hardness):
        """The load cell's force [N] (tension positive) with the switched-on gas, seal and inertia terms."""
        p = self.params
        total = self.valve_force(v, hardness)
        if "gas_force" in self.effects:
            total = total - (p.gas_preload - p.gas_rate * np.asarray(x))
        if "seal_friction" in self.effects:
            total = total + p.seal_friction * np.tanh(np.asarray(v) / p.friction_velocity)
        if "inertia" in self.effects:
            total = total + p.moving_mass * np.asarray(a)
        return total

    def simulate(
        self, dt: float, x: np.ndarray, v: np.ndarray, a: np.ndarray, current: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Force [N] and states (shape (n, 1): the opening) along a motion and valve current [A] every `dt` [s]."""
        h = self.hardness(dt, np.asarray(current, dtype=float))
        return self.force(x, v, a, h), h[:, None]
