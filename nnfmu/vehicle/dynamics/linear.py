"""Linear(ised) vehicle model in state space and its exact discrete-time solution between communication points.

Continuous model, with u the inputs (actuator displacements and velocities, external forces/torques), g the forces of
built-in nonlinear elements (spline dampers) and f the constant gravity + preload term:

    x' = A x + B u + Bn g(Cn x + Dn u) + f
    y  = C x + D u + Dyn g(Cn x + Dn u) + e

Discretisation (`discretise`) is exact for the linear part: the matrix exponential of the augmented matrix gives
x[k+1] = Ad x[k] + Bd0 u[k] + Bd1 u[k+1] + fd. With a zero-order hold (`hold="zoh"`, what an FMU gets: inputs set
at t_k held over the step) Bd1 = 0. With a first-order hold (`hold="foh"`: inputs linear between samples, for offline
simulation of sampled drive files where u[k+1] is known) Bd1 != 0.

The nonlinear forces g (spline dampers) are not exact: a model with such elements takes `substeps` equal sub-steps per
step (<= max_substep), and over each sub-step g is taken linear in time from its value at the sub-step start to its
value at a predicted end state (explicit predictor-corrector: predict with g held, correct with the ramp of g), so the
linear part stays exact and the error of the nonlinear part falls with the square of the sub-step.

Stabilised force ports (rows of `stabiliser` S, the ports' linear reference elements): over a step from x[k] the
vehicle applies the force u set at the step start plus S (x(t) - x[k]), i.e. x' = (A + B S) x + B (u - S x[k]) + ...,
still exact for the linear part; with a first-order hold such a port keeps its start value (its deviation from the
reference is held over the step, never interpolated). A stiff component (a bushing of kN/mm on a light arm) coupled
through a force held for a step then acts on the vehicle with only its deviation from the reference held, which keeps
the exchange stable at steps its own modes would otherwise forbid; at the sample itself the applied force is u, so the
outputs and the continuous model are those of a plain external port.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from nnfmu.vehicle.dynamics.builtin_elements import SplineDamper
from nnfmu.vehicle.dynamics.errors import VehicleModelError
from nnfmu.vehicle.dynamics.ports import VehiclePort

HOLDS = ("zoh", "foh")


@dataclass
class LinearVehicle:
    """A vehicle model as matrices with named ports. Shapes: A (nx, nx), B (nx, nu), C (ny, nx), D (ny, nu).

    `gravity` and `preload` (nx,) add up to the constant term f; `e` (ny,) is the constant output term (static loads).
    Bn (nx, nn), Cn (nn, nx), Dn (nn, nu), Dyn (ny, nn) connect the nn nonlinear built-in elements `feedback_laws`.
    `stabiliser` (nu, nx): the stabilised force ports' reference force S x (zero rows elsewhere; None: no such port);
    `stabiliser_rows` (nu, nx / 2): each such port's deflection as a row over the coordinates q, so that its row of S
    is [k r, c r] with its element's stiffness k and damping c, `stabiliser_elements` (nu, 2).
    """

    name: str
    description: str
    states: list[VehiclePort]
    inputs: list[VehiclePort]
    outputs: list[VehiclePort]
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    e: np.ndarray
    gravity: np.ndarray
    preload: np.ndarray
    feedback_names: list[str]
    feedback_laws: list[SplineDamper]
    Bn: np.ndarray
    Cn: np.ndarray
    Dn: np.ndarray
    Dyn: np.ndarray
    stabiliser: np.ndarray | None = None
    stabiliser_rows: np.ndarray | None = None
    stabiliser_elements: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.stabiliser is None:
            self.stabiliser = np.zeros((len(self.inputs), len(self.states)))
        if self.stabiliser_rows is None:
            self.stabiliser_rows = np.zeros((len(self.inputs), len(self.states) // 2))
        if self.stabiliser_elements is None:
            self.stabiliser_elements = np.zeros((len(self.inputs), 2))

    @property
    def stabilised_A(self) -> np.ndarray:
        """A + B S: the state matrix over a step, stabilised ports' reference elements built in."""
        return self.A + self.B @ self.stabiliser

    @property
    def stabilised_inputs(self) -> np.ndarray:
        """Boolean mask of the inputs that are stabilised force ports (a nonzero row of `stabiliser`)."""
        return np.any(self.stabiliser != 0.0, axis=1)

    @property
    def f(self) -> np.ndarray:
        """Constant term of the state equation: gravity plus the preloads that hold the design position."""
        return self.gravity + self.preload

    @property
    def is_linear(self) -> bool:
        return not self.feedback_laws

    @property
    def input_names(self) -> list[str]:
        return [p.name for p in self.inputs]

    @property
    def output_names(self) -> list[str]:
        return [p.name for p in self.outputs]

    def input_index(self, name: str) -> int:
        return _index(self.inputs, name, f"{self.name}: no input port")

    def output_index(self, name: str) -> int:
        return _index(self.outputs, name, f"{self.name}: no output port")

    def input_vector(self, values: Mapping[str, float]) -> np.ndarray:
        """Input vector from named values; ports not named are zero, unknown names raise VehicleModelError."""
        u = np.zeros(len(self.inputs))
        for name, value in values.items():
            u[self.input_index(name)] = value
        return u

    def nonlinear_forces(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Forces g of the built-in nonlinear elements in state x with inputs u."""
        v = self.Cn @ x + self.Dn @ u
        return np.array([law(vi) for law, vi in zip(self.feedback_laws, v)], dtype=float).reshape(len(v))

    def output_vector(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """y = C x + D u + Dyn g + e."""
        return self.C @ x + self.D @ u + self.Dyn @ self.nonlinear_forces(x, u) + self.e

    def derivative(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """x' = A x + B u + Bn g + f."""
        return self.A @ x + self.B @ u + self.Bn @ self.nonlinear_forces(x, u) + self.f

    def equilibrium(self, u: np.ndarray | None = None) -> np.ndarray:
        """Static state for constant inputs u (default: all zero); rate inputs (unit '.../s') are taken as zero.
        A stabilised port at rest is taken to carry its reference element's force."""
        u = np.zeros(len(self.inputs)) if u is None else np.asarray(u, dtype=float).copy()
        u[[i for i, port in enumerate(self.inputs) if port.unit.endswith("/s")]] = 0.0
        g = np.array([law(v) for law, v in zip(self.feedback_laws, self.Dn @ u)], dtype=float).reshape(
            len(self.feedback_laws)
        )
        a = self.stabilised_A
        if np.linalg.cond(a) > 1e12:
            raise VehicleModelError(
                f"{self.name}: no unique static equilibrium: the stiffness is singular, as happens when external "
                "components (bushings) carry the only stiffness of some motion; give the initial state x0 instead"
            )
        return np.linalg.solve(a, -(self.B @ u + self.Bn @ g + self.f))

    def natural_frequencies(self) -> np.ndarray:
        """Damped natural frequencies [Hz] of the linear part (one per oscillating mode), ascending."""
        eig = np.linalg.eigvals(self.A)
        return np.sort(np.abs(eig[eig.imag > 0].imag)) / (2.0 * math.pi)

    def discretise(self, dt: float, hold: str = "zoh", max_substep: float = 1e-4) -> "DiscreteVehicle":
        """Exact discrete-time model for step `dt` [s]; a nonlinear model is sub-stepped at <= `max_substep` [s]."""
        if not (dt > 0.0 and math.isfinite(dt)):
            raise VehicleModelError(f"{self.name}: step size {dt!r} must be a positive finite number of seconds")
        if hold not in HOLDS:
            raise VehicleModelError(f"{self.name}: hold {hold!r}; expected one of {', '.join(HOLDS)}")
        substeps = 1 if self.is_linear else max(1, math.ceil(dt / max_substep - 1e-9))
        h = dt / substeps
        nx, nu = self.B.shape
        held = np.hstack([self.B, self.Bn, self.f.reshape(nx, 1)])
        a = self.stabilised_A
        gamma, ad = _zoh(a, held, h)
        bd0, bnd, fd = gamma[:, :nu], gamma[:, nu:-1], gamma[:, -1]
        bd1 = np.zeros_like(bd0)
        if hold == "foh":
            ramp = ramp_integral(a, self.B, h)
            bd0, bd1 = bd0 - ramp / h, ramp / h
        bnr = ramp_integral(a, self.Bn, h) / h
        return DiscreteVehicle(self, dt, hold, substeps, ad, bd0, bd1, bnd, bnr, fd)


def _index(ports: list[VehiclePort], name: str, what: str) -> int:
    for i, port in enumerate(ports):
        if port.name == name:
            return i
    raise VehicleModelError(f"{what} {name!r} (has: {', '.join(p.name for p in ports)})")


def _zoh(a: np.ndarray, b: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(integral_0^h e^{A s} ds B, e^{A h}) from one exponential of [[A, B], [0, 0]] h."""
    nx, nb = b.shape
    aug = np.zeros((nx + nb, nx + nb))
    aug[:nx, :nx] = a
    aug[:nx, nx:] = b
    e = expm(aug * h)
    return e[:nx, nx:], e[:nx, :nx]


def ramp_integral(a: np.ndarray, b: np.ndarray, h: float) -> np.ndarray:
    """Response at h to an input ramp of unit slope starting at 0 from rest: integral_0^h e^{A(h-s)} B s ds."""
    nx, nb = b.shape
    aug = np.zeros((nx + 2 * nb, nx + 2 * nb))
    aug[:nx, :nx] = a
    aug[:nx, nx : nx + nb] = b
    aug[nx : nx + nb, nx + nb :] = np.eye(nb)
    e = expm(aug * h)
    return e[:nx, nx + nb :]


@dataclass
class DiscreteVehicle:
    """x[k+1] = Ad x[k] + Bd0 u[k] + Bd1 u[k+1] + fd per step of `dt` for a linear model (`substeps` = 1, exact).

    With nonlinear built-in elements, per sub-step (u interpolated between u[k] and u[k+1] for foh, held for zoh):
    g0 = g(x, u0); x_pred = Ad x + Bd0 u0 + Bd1 u1 + Bnd g0 + fd; x_next = x_pred + Bnr (g(x_pred, u1) - g0).
    Bnd is the held-force response and Bnr the response to a unit-per-sub-step force ramp. The matrices are those of
    the stabilised state matrix, and every input is taken less S x at the step start (`held_inputs`).
    """

    vehicle: LinearVehicle
    dt: float
    hold: str
    substeps: int
    Ad: np.ndarray
    Bd0: np.ndarray
    Bd1: np.ndarray
    Bnd: np.ndarray
    Bnr: np.ndarray
    fd: np.ndarray

    def step(self, x: np.ndarray, u: np.ndarray, u_next: np.ndarray | None = None) -> np.ndarray:
        """State one step later from state x, inputs u now and (for foh) u_next at the step end."""
        if self.hold == "foh" and u_next is None:
            raise VehicleModelError(f"{self.vehicle.name}: a first-order hold step needs the inputs at the step end")
        end = u if u_next is None or self.hold == "zoh" else np.where(self.vehicle.stabilised_inputs, u, u_next)
        u, end = self.held_inputs(x, u), self.held_inputs(x, end)
        for j in range(self.substeps):
            u0 = u + (end - u) * (j / self.substeps)
            u1 = u + (end - u) * ((j + 1) / self.substeps)
            x_pred = self.Ad @ x + self.Bd0 @ u0 + self.Bd1 @ u1 + self.fd
            if self.vehicle.is_linear:
                x = x_pred
                continue
            g0 = self.vehicle.nonlinear_forces(x, u0)
            x_pred = x_pred + self.Bnd @ g0
            x = x_pred + self.Bnr @ (self.vehicle.nonlinear_forces(x_pred, u1) - g0)
        return x

    def held_inputs(self, x_start: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Inputs as the stabilised step sees them: u - S x at the step start (u itself without stabilised ports)."""
        return u - self.vehicle.stabiliser @ x_start


@dataclass(frozen=True)
class SimulationSettings:
    """Fixed-step simulation: step `dt` [s], input `hold` ('zoh' or 'foh'), sub-step limit for nonlinear elements
    [s]."""

    dt: float
    hold: str = "zoh"
    max_substep: float = 1e-4


InputFunction = Callable[[float], Mapping[str, float]]


def simulate(
    vehicle: LinearVehicle,
    inputs: Mapping[str, np.ndarray] | InputFunction,
    settings: SimulationSettings,
    steps: int | None = None,
    x0: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Simulate from x0 (default: static equilibrium at the first inputs); returns every output and 'time' [s].

    `inputs` maps port names to arrays sampled at t_k = k dt (ports not given are zero), or is a function of time
    returning such a mapping of floats (then `steps` is required). Outputs are sampled at the same instants.
    """
    u = input_samples(vehicle, inputs, settings.dt, steps)
    n = u.shape[0]
    discrete = vehicle.discretise(settings.dt, settings.hold, settings.max_substep)
    x = vehicle.equilibrium(u[0]) if x0 is None else np.asarray(x0, dtype=float)
    if x.shape != (len(vehicle.states),):
        raise VehicleModelError(f"{vehicle.name}: initial state has shape {x.shape}; expected ({len(vehicle.states)},)")
    y = np.empty((n, len(vehicle.outputs)))
    for k in range(n):
        y[k] = vehicle.output_vector(x, u[k])
        if k + 1 < n:
            x = discrete.step(x, u[k], u[k + 1])
    result = {name: y[:, i] for i, name in enumerate(vehicle.output_names)}
    result["time"] = np.arange(n) * settings.dt
    return result


def input_samples(
    vehicle: LinearVehicle, inputs: Mapping[str, np.ndarray] | InputFunction, dt: float, steps: int | None
) -> np.ndarray:
    """(n, nu) matrix of input samples from arrays or from a function of time (ports not given are zero)."""
    if callable(inputs):
        if steps is None or steps < 1:
            raise VehicleModelError(f"{vehicle.name}: an input function needs the number of steps (got {steps!r})")
        return np.array([vehicle.input_vector(inputs(k * dt)) for k in range(steps)])
    if not inputs:
        if steps is None or steps < 1:
            raise VehicleModelError(f"{vehicle.name}: no inputs given and no number of steps")
        return np.zeros((steps, len(vehicle.inputs)))
    lengths = {name: np.shape(values) for name, values in inputs.items()}
    n = steps if steps is not None else len(next(iter(inputs.values())))
    bad = {name: shape for name, shape in lengths.items() if shape != (n,)}
    if bad:
        raise VehicleModelError(f"{vehicle.name}: input arrays must all have shape ({n},); got {bad}")
    u = np.zeros((n, len(vehicle.inputs)))
    for name, values in inputs.items():
        values = np.asarray(values, dtype=float)
        if not np.all(np.isfinite(values)):
            raise VehicleModelError(f"{vehicle.name}: input {name!r} holds NaN or Inf")
        u[:, vehicle.input_index(name)] = values
    return u
