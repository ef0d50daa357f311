"""Truth physics of a passenger-car damper on a dyno: digressive asymmetric valve, compliance, gas, seal, heat, mass.

Sign convention: displacement x [m] is extension from mid-stroke (rebound positive), force [N] is the tension the
damper carries (rebound force positive, jounce force negative), as in the thesis' force-velocity splines.

Parameter ranges (mid-size passenger car, front axle): textbook values after Dixon, *The Shock Absorber Handbook*
(2nd ed., 2007: characteristics, gas force, friction, temperature) and Reimpell & Stoll, *The Automotive Chassis*.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nnfmu.errors import SettingsError
from nnfmu.physics.effects import DAMPER_EFFECTS, DEFAULT_EFFECTS
from nnfmu.physics.parameters import param


@dataclass(frozen=True)
class ValveSide:
    """One direction of the digressive valve: bleed line c_low·u, blow-off line F_b + c_high·u, joined by a hyperbola.

    The hyperbola passes `rounding` [N] below the corner of the two lines at `knee_velocity`; it is shifted to pass
    through zero. Both the force of a speed and the speed of a force are closed-form (a quadratic), which the
    compliance model needs. Typical: knee 0.1-0.3 m/s, high-speed slope 1/4-1/8 of the bleed slope (Dixon).
    """

    c_low: float = param(8000.0, "N.s/m", "bleed (low-speed) damping slope")
    c_high: float = param(1300.0, "N.s/m", "slope after blow-off (high speed)")
    knee_velocity: float = param(0.15, "m/s", "velocity where the bleed and blow-off lines meet")
    rounding: float = param(150.0, "N", "how far the curve passes below the corner of the two lines")

    def __post_init__(self) -> None:
        if not (self.c_low > self.c_high > 0 and self.knee_velocity > 0 and self.rounding > 0):
            raise SettingsError(
                f"a digressive valve needs c_low > c_high > 0, knee_velocity > 0 and rounding > 0; got {self}"
            )

    @property
    def blow_off(self) -> float:
        """Force [N] where the blow-off line meets zero speed."""
        return (self.c_low - self.c_high) * self.knee_velocity

    @property
    def offset(self) -> float:
        """Force [N] of the unshifted hyperbola at zero speed; subtracted, so the curve passes through zero."""
        fb = self.blow_off
        return 0.5 * (fb - (fb * fb + 4 * self.rounding**2) ** 0.5)

    def force(self, u):
        """Force [N] at speed u >= 0 [m/s] (float or array)."""
        l1, l2 = self.c_low * u, self.blow_off + self.c_high * u
        return 0.5 * ((l1 + l2) - ((l1 - l2) ** 2 + 4 * self.rounding**2) ** 0.5) - self.offset

    def slope(self, u):
        """dF/du [N.s/m] at speed u >= 0."""
        d = self.c_low * u - self.blow_off - self.c_high * u
        spread = self.c_low - self.c_high
        return 0.5 * ((self.c_low + self.c_high) - d * spread / (d * d + 4 * self.rounding**2) ** 0.5)

    def speed(self, f: float) -> float:
        """Speed u >= 0 [m/s] at which the side carries force f >= 0 [N] (scalar; the larger root of the quadratic)."""
        return _speed(self.constants, f)

    @property
    def constants(self) -> tuple[float, ...]:
        """(c_low, c_high, blow-off force, offset, rounding², c_low·c_high): what the scalar functions need, each
        computed once (a simulation asks for them millions of times)."""
        return (self.c_low, self.c_high, self.blow_off, self.offset, self.rounding**2, self.c_low * self.c_high)


def _speed(constants: tuple[float, ...], f: float) -> float:
    """`ValveSide.speed` from the side's `constants`."""
    c_low, c_high, fb, offset, rounding2, a = constants
    fh = f + offset
    b = c_low * (fb - fh) - c_high * fh
    c = -fh * (fb - fh) - rounding2
    root = math.sqrt(max(b * b - 4 * a * c, 0.0))
    u = -2 * c / (b + root) if b > 0 else (root - b) / (2 * a)
    return max(u, 0.0)


def _slope(constants: tuple[float, ...], u: float) -> float:
    """`ValveSide.slope` at a scalar speed u >= 0 from the side's `constants`."""
    c_low, c_high, fb, _, rounding2, _ = constants
    d = c_low * u - fb - c_high * u
    return 0.5 * ((c_low + c_high) - d * (c_low - c_high) / (d * d + 4 * rounding2) ** 0.5)


@dataclass(frozen=True)
class DamperParams:
    """Mid-size passenger car front damper. Peak force ~3 kN rebound / ~1.25 kN jounce at 1.5 m/s (ratio ~2.4)."""

    rebound: ValveSide = ValveSide(c_low=8000.0, c_high=1300.0, knee_velocity=0.15, rounding=150.0)
    jounce: ValveSide = ValveSide(c_low=3000.0, c_high=500.0, knee_velocity=0.20, rounding=80.0)
    series_stiffness: float = param(
        2.0e6, "N/m", "oil/gas column and mount compliance in series with the valve; lag c/k = 0.25-4 ms (Dixon)"
    )
    gas_preload: float = param(250.0, "N", "gas force at mid-stroke, pushing the rod out (150-400 N, Dixon)")
    gas_rate: float = param(1000.0, "N/m", "rise of the gas force per m of compression (0.5-2 N/mm)")
    seal_friction: float = param(50.0, "N", "Coulomb level of rod seal and guide friction (30-80 N, Dixon)")
    friction_velocity: float = param(0.002, "m/s", "velocity scale of the tanh-smoothed Coulomb friction")
    presliding_stiffness: float = param(
        2.5e5, "N/m", "seal stiffness before break-away ('presliding'): the seal's lip deflects 0.2 mm at 50 N"
    )
    heat_capacity: float = param(1000.0, "J/K", "oil (~0.3 L) and steel tube (~1.5 kg) heat capacity")
    heat_conductance: float = param(2.0, "W/K", "convective loss to ambient, h*A (~40 W/m^2K * 0.05 m^2)")
    fade: float = param(0.004, "1/K", "relative fall of damping per K of oil heating (0.2-0.5 %/K, Dixon)")
    ambient_temperature: float = param(293.15, "K", "ambient and initial oil temperature; damping is nominal here")
    moving_mass: float = param(2.0, "kg", "rod, piston and fixture mass between load cell and actuator (1-3 kg)")


@dataclass(frozen=True)
class DamperTruth:
    """The damper's force from its state and the prescribed motion; usable inside any ODE integrator.

    States (only those of the switched-on effects, in this order): `valve_force` [N] (hysteresis: the force carried
    by the series stiffness k_s, F' = k_s (v - v_valve(F/s))), `temperature` [K] (C T' = F·v_valve - hA (T - T_amb)),
    `seal_force` [N] (presliding: the seal friction as a Jenkins element, a spring k_p in series with a Coulomb slider
    F_c: S' = k_p v while |S| < F_c or the motion unloads it, else 0; it replaces the tanh-smoothed Coulomb friction).
    s(T) = exp(-fade (T - T_amb)) scales the valve characteristic.
    """

    params: DamperParams = field(default_factory=DamperParams)
    effects: tuple[str, ...] = DEFAULT_EFFECTS["damper"]

    def __post_init__(self) -> None:
        unknown = [e for e in self.effects if e not in DAMPER_EFFECTS]
        if unknown:
            raise SettingsError(f"unknown damper effect(s) {unknown}; valid: {', '.join(DAMPER_EFFECTS)}")
        if "presliding" in self.effects and "seal_friction" not in self.effects:
            raise SettingsError(
                "the damper effect 'presliding' is a property of the seal: switch on 'seal_friction' too"
            )
        if "presliding" in self.effects and not self.params.presliding_stiffness > 0:
            raise SettingsError(f"presliding_stiffness must be > 0 N/m, got {self.params.presliding_stiffness!r}")

    @property
    def state_names(self) -> tuple[str, ...]:
        names = {"hysteresis": "valve_force", "temperature": "temperature", "presliding": "seal_force"}
        return tuple(names[e] for e in DAMPER_EFFECTS if e in names and e in self.effects)

    @property
    def n_states(self) -> int:
        return len(self.state_names)

    def initial_state(self) -> np.ndarray:
        """A damper at rest at ambient temperature."""
        return np.array([self.params.ambient_temperature if n == "temperature" else 0.0 for n in self.state_names])

    def characteristic(self, v):
        """Nominal valve force [N] at velocity v [m/s] (float or array): rebound for v > 0, jounce for v < 0."""
        p = self.params
        v = np.asarray(v, dtype=float)
        return np.where(v >= 0, p.rebound.force(np.maximum(v, 0)), -p.jounce.force(np.maximum(-v, 0)))

    def valve_velocity(self, force: float) -> float:
        """Inverse of the nominal characteristic: the valve velocity [m/s] that carries `force` [N] (scalar)."""
        if force >= 0:
            return self.params.rebound.speed(force)
        return -self.params.jounce.speed(-force)

    def valve_slope(self, velocity: float) -> float:
        """dF/dv [N.s/m] of the nominal characteristic at `velocity` (scalar)."""
        side = self.params.rebound if velocity >= 0 else self.params.jounce
        return float(side.slope(abs(velocity)))

    def damping_scale(self, temperature):
        """Factor on the valve characteristic at oil `temperature` [K]: 1 at ambient, falling by `fade` per K."""
        return np.exp(-self.params.fade * (np.asarray(temperature) - self.params.ambient_temperature))

    def gas_force(self, x):
        """Outward push of the gas spring [N] at extension x [m]: the preload at mid-stroke, rising on compression."""
        return self.params.gas_preload - self.params.gas_rate * np.asarray(x)

    def friction_force(self, v):
        """Seal friction [N] opposing the motion (tension positive): smoothed Coulomb F_c tanh(v/v_s)."""
        return self.params.seal_friction * np.tanh(np.asarray(v) / self.params.friction_velocity)

    def seal_force_rate(self, seal_force: float, v: float) -> float:
        """d(seal_force)/dt [N/s] of the Jenkins element at velocity v [m/s]: the pre-sliding stiffness times v,
        0 while it slides (at the break-away force and loaded further)."""
        p = self.params
        sliding = abs(seal_force) >= p.seal_friction and seal_force * v > 0
        return 0.0 if sliding else p.presliding_stiffness * v

    def _unpack(self, state: np.ndarray) -> tuple[float | None, float]:
        names = self.state_names
        valve = float(state[names.index("valve_force")]) if "valve_force" in names else None
        temp = float(state[names.index("temperature")]) if "temperature" in names else self.params.ambient_temperature
        return valve, temp

    def derivatives(self, t: float, state: np.ndarray, x: float, v: float) -> np.ndarray:
        """d(state)/dt at time t [s] for displacement x [m] and velocity v [m/s]."""
        p = self.params
        valve, temp = self._unpack(state)
        scale = float(self.damping_scale(temp))
        out = []
        if valve is not None:
            valve_velocity = self.valve_velocity(valve / scale)
            power = valve * valve_velocity
            out.append(p.series_stiffness * (v - valve_velocity))
        else:
            power = scale * float(self.characteristic(v)) * v
        if "temperature" in self.effects:
            out.append((power - p.heat_conductance * (temp - p.ambient_temperature)) / p.heat_capacity)
        if "presliding" in self.effects:
            out.append(self.seal_force_rate(float(state[self.state_names.index("seal_force")]), v))
        return np.array(out)

    def force(self, state, x, v, a):
        """Measured force [N] (tension positive) for the state(s), displacement, velocity and acceleration.

        `state` has shape (n_states,) or (n, n_states) with x, v, a of shape (n,).
        """
        state = np.asarray(state, dtype=float)
        names = self.state_names
        if "valve_force" in names:
            total = state[..., names.index("valve_force")]
        else:
            temp = state[..., names.index("temperature")] if "temperature" in names else self.params.ambient_temperature
            total = self.damping_scale(temp) * self.characteristic(v)
        if "gas_force" in self.effects:
            total = total - self.gas_force(x)
        if "presliding" in self.effects:
            total = total + state[..., names.index("seal_force")]
        elif "seal_friction" in self.effects:
            total = total + self.friction_force(v)
        if "inertia" in self.effects:
            total = total + self.params.moving_mass * np.asarray(a)
        return total

    def simulate(self, dt: float, x: np.ndarray, v: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Force [N] and states (shape (n, n_states)) along a prescribed motion sampled every `dt` [s].

        The valve force follows the trapezoidal rule (A-stable, 2nd order) solved by Newton's method with the exact
        inverse characteristic; the temperature, far slower, follows explicit Euler; the seal's Jenkins element is
        exact for the displacement's steps (its force moves by k_p·Δx, clipped to ±F_c). Keep dt <= 0.5 ms.
        """
        if self.n_states == 0:
            states = np.empty((len(x), 0))
            return self.force(states, x, v, a), states
        p = self.params
        has_valve = "valve_force" in self.state_names
        has_temp = "temperature" in self.effects
        has_seal = "presliding" in self.effects
        seal = 0.0
        valve, temp = self._unpack(self.initial_state())
        scale = 1.0
        valve_velocity = 0.0
        half = 0.5 * dt * p.series_stiffness
        # Python floats and local names in the loop: the same IEEE arithmetic as on numpy scalars, several times
        # faster per operation (a dyno record is hundreds of thousands of samples).
        velocities, displacements = np.asarray(v, dtype=float).tolist(), np.asarray(x, dtype=float).tolist()
        nominal_power = (self.characteristic(v) * v).tolist()
        rebound, jounce = p.rebound.constants, p.jounce.constants
        fade, ambient, conductance, capacity = p.fade, p.ambient_temperature, p.heat_conductance, p.heat_capacity
        presliding, seal_friction = p.presliding_stiffness, p.seal_friction
        columns: tuple[list[float], list[float], list[float]] = ([valve or 0.0], [temp], [seal])

        def valve_velocity_of(force: float) -> float:  # `valve_velocity`, without its lookups per call
            return _speed(rebound, force) if force >= 0 else -_speed(jounce, -force)

        for i in range(1, len(displacements)):
            if has_temp:
                scale = math.exp(-fade * (temp - ambient))
            if has_valve:
                old_valve, old_rate = valve, velocities[i - 1] - valve_velocity
                guess = valve + 2 * half * old_rate
                for _ in range(30):
                    w = valve_velocity_of(guess / scale)
                    residual = guess - old_valve - half * (old_rate + velocities[i] - w)
                    slope = _slope(rebound, w) if w >= 0 else _slope(jounce, -w)
                    step = residual / (1 + half / (scale * slope))
                    guess -= step
                    if abs(step) < 1e-9 * (1 + abs(guess)):
                        break
                valve = guess
                new_velocity = valve_velocity_of(valve / scale)
                power = 0.5 * (old_valve * valve_velocity + valve * new_velocity)
                valve_velocity = new_velocity
                columns[0].append(valve)
            else:
                power = scale * nominal_power[i - 1]
            if has_temp:
                temp += dt * (power - conductance * (temp - ambient)) / capacity
                columns[1].append(temp)
            if has_seal:
                seal = min(
                    max(seal + presliding * (displacements[i] - displacements[i - 1]), -seal_friction), seal_friction
                )
                columns[2].append(seal)
        on = (has_valve, has_temp, has_seal)
        states = np.column_stack([np.asarray(c, dtype=float) for c, kept in zip(columns, on, strict=True) if kept])
        return self.force(states, x, v, a), states
