"""Monolithic reference: the vehicle and its components' force laws in one fixed-step RK4 solver at a fine step.

This is the "ground truth" a co-simulation of the same vehicle with component FMUs must approach: no communication
step, no force held over a step. Each external force port of the vehicle is closed by a `ComponentLaw` driven by the
port's displacement and rate outputs. Inputs (actuator displacements and velocities) are sampled at the drive's
sample period and interpolated linearly between samples; built-in spline dampers are evaluated at every stage.

Two paths solve the same equations with the same RK4 arithmetic: a compiled kernel (`rk4_kernel`, numba) for the
laws it knows (`law_tables`: `LinearLaw`, `DamperTruthLaw`, `BushingTruthLaw`, exactly those types, which is what
`truth_laws` and `linear_laws` make), and the generic path, which calls each law's own `force` and `derivatives` at
every stage and so takes any `ComponentLaw`. A single law of another type sends the whole run down the generic path,
which is 10-100x slower.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.optimize import root
from scipy.sparse import csr_array

from nnfmu.kinds import element_of_port
from nnfmu.vehicle.dynamics.errors import VehicleModelError
from nnfmu.vehicle.dynamics.kernel_warmup import wait_for_kernel
from nnfmu.vehicle.dynamics.law_tables import LawTable, law_table, spline_table
from nnfmu.vehicle.dynamics.laws import BushingTruthBank, BushingTruthLaw, ComponentLaw
from nnfmu.vehicle.dynamics.linear import LinearVehicle, input_samples
from nnfmu.vehicle.dynamics.ports import component_channels


@dataclass(frozen=True)
class MonolithicSettings:
    """`sample_period` [s] of the inputs and outputs; `step` [s], the RK4 step (rounded down to divide the period);
    `compiled`: use the compiled kernel when it knows every law (False: always the generic path, for cross-checks)."""

    sample_period: float
    step: float = 1e-4
    compiled: bool = True


Solved = tuple[np.ndarray, np.ndarray, int]  # vehicle states and port forces at the samples, samples solved


@dataclass(frozen=True)
class _Wiring:
    """Which input columns the laws set and which output rows give each law its deflection and rate."""

    force_columns: np.ndarray
    disp_rows: np.ndarray
    rate_rows: np.ndarray


def _wire(vehicle: LinearVehicle, laws: Mapping[str, ComponentLaw]) -> _Wiring:
    ports = {force: (disp, rate) for name in _components(vehicle) for force, disp, rate in component_channels(name)}
    unknown = sorted(set(laws) - set(ports))
    missing = sorted(set(ports) - set(laws))
    if unknown or missing:
        raise VehicleModelError(f"{vehicle.name}: laws for unknown ports {unknown}, no law for ports {missing}")
    names = list(laws)
    force_columns = np.array([vehicle.input_index(n) for n in names], dtype=int)
    return _Wiring(
        force_columns=force_columns,
        disp_rows=np.array([vehicle.output_index(ports[n][0]) for n in names], dtype=int),
        rate_rows=np.array([vehicle.output_index(ports[n][1]) for n in names], dtype=int),
    )


class _OneLaw:
    """A single law on length-1 arrays, so the solver treats it like a bank."""

    def __init__(self, law: ComponentLaw) -> None:
        self.law = law
        self.n_states = law.n_states

    def initial_state(self) -> np.ndarray:
        return self.law.initial_state()

    def derivatives(self, t: float, state: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.law.derivatives(t, state, x[0], v[0])

    def forces(self, state: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.array([self.law.force(state, x[0], v[0])])


def _groups(laws: list[ComponentLaw]) -> list[tuple[_OneLaw | BushingTruthBank, np.ndarray]]:
    """The laws as groups evaluated together, each with the indices of its laws: bushing truth laws of one state
    layout form a bank, every other law is its own group."""
    groups: list[tuple[_OneLaw | BushingTruthBank, np.ndarray]] = []
    layouts: dict[tuple[int, int], list[int]] = {}
    for i, law in enumerate(laws):
        if isinstance(law, BushingTruthLaw):
            layouts.setdefault((law.truth.n_maxwell, law.truth.n_friction), []).append(i)
        else:
            groups.append((_OneLaw(law), np.array([i])))
    for members in layouts.values():
        groups.append((BushingTruthBank([laws[i] for i in members]), np.array(members)))
    return groups


def _components(vehicle: LinearVehicle) -> list[str]:
    """Component names of the vehicle's force inputs ('damper_fl', 'bushing_fl_front', 'damper')."""
    names = []
    for port in vehicle.inputs:
        if port.name.startswith("actuator"):
            continue
        stem = element_of_port(port.name)
        if stem is None:
            raise VehicleModelError(
                f"force input {port.name!r} is no port of a registered component kind (nnfmu.kinds)"
            )
        if stem not in names:
            names.append(stem)
    return names


def simulate_monolithic(
    vehicle: LinearVehicle,
    laws: Mapping[str, ComponentLaw],
    inputs: Mapping[str, np.ndarray],
    settings: MonolithicSettings,
    x0: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Solve vehicle + laws from x0 (default: the design position, laws at rest); outputs, port forces and 'time'.

    `laws` maps every force input of the vehicle (e.g. 'damper_fl_force') to its law; `inputs` the actuator ports to
    arrays sampled every `settings.sample_period` (ports not given are zero).
    """
    wiring = _wire(vehicle, laws)
    law_list = list(laws.values())
    period = settings.sample_period
    substeps = max(1, math.ceil(period / settings.step - 1e-9))
    h = period / substeps
    if not inputs:
        raise VehicleModelError(f"{vehicle.name}: the monolithic reference needs actuator input arrays")
    closed = sorted(k for k in inputs if vehicle.input_index(k) in set(wiring.force_columns))
    if closed:
        raise VehicleModelError(f"{vehicle.name}: inputs {closed} are force ports that the laws close")
    u_samples = input_samples(vehicle, inputs, period, None)
    x = np.zeros(len(vehicle.states)) if x0 is None else np.asarray(x0, dtype=float)
    table = law_table(law_list) if settings.compiled else None
    if table is None:
        states, port_forces, solved = _solve_generic(vehicle, law_list, wiring, x, u_samples, substeps, h)
    else:
        states, port_forces, solved = _solve_compiled(vehicle, table, wiring, x, u_samples, substeps, h)
    n = u_samples.shape[0]
    if solved < n:
        raise VehicleModelError(
            f"{vehicle.name}: monolithic solution diverged at t = {solved * period:.6g} s; use a smaller step"
        )
    applied = u_samples.copy()
    applied[:, wiring.force_columns] = port_forces
    out = _outputs(vehicle, states, applied)
    result = {name: out[:, i] for i, name in enumerate(vehicle.output_names)}
    result |= {name: port_forces[:, i] for i, name in enumerate(laws)}
    result["time"] = np.arange(n) * period
    return result


def rest_state(vehicle: LinearVehicle, laws: Mapping[str, ComponentLaw], start: np.ndarray) -> np.ndarray:
    """The static state of the vehicle standing on `laws` for zero actuator input, every law relaxed (its initial
    state) and at rest: where the laws' own static forces hold the car up. A vehicle's `equilibrium` holds it on its
    linear reference elements instead; where a law is stiffer or softer than its element (a rear bushing carrying the
    front bushing's physics), a run started there is not at rest and rings through the first tenths of a second.
    Solved from `start` (e.g. that linear equilibrium) with scipy's hybrid Powell method, else Newton's method with a
    central-difference Jacobian (hybrid Powell did not move from the start on a lab car with the gas force of two
    dampers switched on, residual 19 m/s^2 in roll; Newton's method converged to 1e-11 in three steps)."""
    wiring = _wire(vehicle, laws)
    law_list = list(laws.values())
    relaxed = [law.initial_state() for law in law_list]

    def inputs(x: np.ndarray) -> np.ndarray:
        u = np.zeros(len(vehicle.inputs))
        deflections = vehicle.output_vector(x, u)[wiring.disp_rows]
        u[wiring.force_columns] = [law.force(state, d, 0.0) for law, state, d in zip(law_list, relaxed, deflections)]
        return u

    start = np.asarray(start, dtype=float)
    scale = max(1.0, float(np.max(np.abs(vehicle.derivative(np.zeros_like(start), np.zeros(len(vehicle.inputs)))))))

    def balance(x: np.ndarray) -> np.ndarray:
        return vehicle.derivative(x, inputs(x))

    solved = root(balance, start, method="hybr", options={"xtol": 1e-13})
    x, message = solved.x, solved.message
    residual = float(np.max(np.abs(balance(x)), initial=0.0))
    if not solved.success or residual > 1e-9 * scale:
        x = _newton(balance, start)
        residual = float(np.max(np.abs(balance(x)), initial=0.0))
        message = "Newton's method after: " + message
    if residual > 1e-9 * scale:
        raise VehicleModelError(
            f"{vehicle.name}: no static rest state on the component laws from the linear "
            f"equilibrium ({message}; largest residual {residual:.3g})"
        )
    return x


def _newton(function, start: np.ndarray, iterations: int = 20, step: float = 1e-8) -> np.ndarray:
    """Newton's method on `function` from `start` with a central-difference Jacobian (step [state unit]); the
    iterate with the smallest residual."""
    x = best = np.asarray(start, dtype=float)
    smallest = float(np.max(np.abs(function(x))))
    for _ in range(iterations):
        columns = [(function(x + step * e) - function(x - step * e)) / (2 * step) for e in np.eye(len(x))]
        x = x + np.linalg.lstsq(np.column_stack(columns), -function(x), rcond=None)[0]
        size = float(np.max(np.abs(function(x))))
        if size < smallest:
            best, smallest = x, size
    return best


def _outputs(vehicle: LinearVehicle, states: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Outputs y = C x + D u + Dyn g + e at every sample (rows of states and inputs)."""
    v = states @ vehicle.Cn.T + u @ vehicle.Dn.T
    g = np.column_stack([law(v[:, i]) for i, law in enumerate(vehicle.feedback_laws)] or [np.zeros((len(u), 0))])
    return states @ vehicle.C.T + u @ vehicle.D.T + g @ vehicle.Dyn.T + vehicle.e


def _solve_compiled(
    vehicle: LinearVehicle,
    table: LawTable,
    wiring: _Wiring,
    x: np.ndarray,
    u_samples: np.ndarray,
    substeps: int,
    h: float,
) -> Solved:
    """The RK4 loop in the compiled kernel; only the output rows the laws read are evaluated at each stage."""
    from nnfmu.vehicle.dynamics import rk4_kernel  # numba takes about a second to load; only solving needs it

    wait_for_kernel()  # a child compiling the kernel for this run: its cached code is loaded, not compiled again
    rows = np.concatenate([wiring.disp_rows, wiring.rate_rows])
    splines = spline_table(vehicle.feedback_laws)
    matrices = (vehicle.A, vehicle.B, vehicle.Bn, vehicle.Cn, vehicle.Dn, vehicle.C[rows], vehicle.D[rows])
    arrays = (
        *(_csr(m) for m in matrices),
        np.ascontiguousarray(vehicle.f, dtype=float),
        wiring.force_columns.astype(np.int64),
    )
    z0 = np.concatenate([x, table.initial_state])
    return rk4_kernel.solve(
        arrays,
        (splines.start, splines.velocity, splines.force),
        (table.layout, table.values),
        z0,
        np.ascontiguousarray(u_samples, dtype=float),
        substeps,
        h,
    )


def _csr(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, data) of a dense matrix, columns in order: the vehicle's matrices are mostly zeros."""
    sparse = csr_array(np.asarray(matrix, dtype=float))
    sparse.sort_indices()
    return sparse.indptr.astype(np.int64), sparse.indices.astype(np.int64), sparse.data.astype(float)


def _solve_generic(
    vehicle: LinearVehicle,
    law_list: list[ComponentLaw],
    wiring: _Wiring,
    x: np.ndarray,
    u_samples: np.ndarray,
    substeps: int,
    h: float,
) -> Solved:
    """The RK4 loop in numpy, calling each law (or bank of bushing laws) at every stage."""
    groups = _groups(law_list)
    nx = len(vehicle.states)
    offsets = nx + np.concatenate([[0], np.cumsum([group.n_states for group, _ in groups])]).astype(int)
    spans = [
        (group, members, wiring.disp_rows[members], wiring.rate_rows[members], a, b)
        for (group, members), a, b in zip(groups, offsets[:-1], offsets[1:])
    ]
    z = np.concatenate([x] + [group.initial_state() for group, _ in groups])

    def forces(z: np.ndarray, u: np.ndarray) -> np.ndarray:
        y = vehicle.C @ z[:nx] + vehicle.D @ u
        f = np.empty(len(law_list))
        for group, members, disp, rate, a, b in spans:
            f[members] = group.forces(z[a:b], y[disp], y[rate])
        return f

    def rhs(t: float, z: np.ndarray, u: np.ndarray) -> np.ndarray:
        u = u.copy()
        u[wiring.force_columns] = forces(z, u)
        y = vehicle.C @ z[:nx] + vehicle.D @ u
        parts = [vehicle.derivative(z[:nx], u)]
        for group, _, disp, rate, a, b in spans:
            parts.append(group.derivatives(t, z[a:b], y[disp], y[rate]))
        return np.concatenate(parts)

    n = u_samples.shape[0]
    states = np.empty((n, nx))
    port_forces = np.empty((n, len(law_list)))
    for k in range(n):
        states[k] = z[:nx]
        port_forces[k] = forces(z, u_samples[k])
        if k + 1 == n:
            break
        du = (u_samples[k + 1] - u_samples[k]) / substeps
        for j in range(substeps):
            t = (k * substeps + j) * h
            u0 = u_samples[k] + du * j
            k1 = rhs(t, z, u0)
            k2 = rhs(t + h / 2, z + h / 2 * k1, u0 + du / 2)
            k3 = rhs(t + h / 2, z + h / 2 * k2, u0 + du / 2)
            k4 = rhs(t + h, z + h * k3, u0 + du)
            z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not np.all(np.isfinite(z)):
            return states, port_forces, k + 1
    return states, port_forces, n
