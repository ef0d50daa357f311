"""Compiled (numba) RK4 loop of the monolithic reference: the vehicle's state equation and the tabled laws.

The same arithmetic as the generic path in `monolithic.simulate_monolithic` (stage order, input interpolation, the
laws' own formulas in `nnfmu.data.rigs`), written as scalar loops so that numba compiles it to machine code: the
per-stage work is a few thousand floating-point operations, which numpy calls on tiny arrays cannot do quickly.
Sums may be taken in another order than numpy's, so results agree to rounding, not bit for bit. The helpers are
inlined into `_rhs` (half the run time of calls that pass arrays); `_rhs` itself is not, which keeps the first
compilation to about 20 s of CPU. That happens once per machine: numba caches the machine code on disk (beside this
file, or in its user-wide cache where that is read-only).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nnfmu.vehicle.dynamics.law_tables import BUSHING, DAMPER, FLAG0, FLAG1, FLAG2, FLAG3, KIND, STATES, VALUES

# Offsets of a damper's numbers in the law values (see law_tables._damper).
_REBOUND, _JOUNCE = 0, 5
_SERIES, _GAS_PRELOAD, _GAS_RATE, _SEAL, _FRICTION_VELOCITY = 10, 11, 12, 13, 14
_HEAT_CAPACITY, _HEAT_CONDUCTANCE, _FADE, _AMBIENT = 15, 16, 17, 18


@njit(inline="always")
def _side_force(values, at, u):
    """ValveSide.force at speed u >= 0 of the side whose numbers start at `at`."""
    c_low, c_high, blow_off, offset = values[at], values[at + 1], values[at + 2], values[at + 3]
    rounding = values[at + 4]
    l1, l2 = c_low * u, blow_off + c_high * u
    return 0.5 * ((l1 + l2) - math.sqrt((l1 - l2) ** 2 + 4 * rounding**2)) - offset


@njit(inline="always")
def _side_speed(values, at, f):
    """ValveSide.speed: the speed u >= 0 at which the side carries force f >= 0."""
    c_low, c_high, fb, offset, rounding = values[at], values[at + 1], values[at + 2], values[at + 3], values[at + 4]
    fh = f + offset
    a = c_low * c_high
    b = c_low * (fb - fh) - c_high * fh
    c = -fh * (fb - fh) - rounding**2
    root = math.sqrt(max(b * b - 4 * a * c, 0.0))
    u = -2 * c / (b + root) if b > 0 else (root - b) / (2 * a)
    return max(u, 0.0)


@njit(inline="always")
def _characteristic(values, at, v):
    """DamperTruth.characteristic: nominal valve force at velocity v (rebound for v >= 0)."""
    if v >= 0:
        return _side_force(values, at + _REBOUND, max(v, 0.0))
    return -_side_force(values, at + _JOUNCE, max(-v, 0.0))


@njit(inline="always")
def _valve_velocity(values, at, force):
    """DamperTruth.valve_velocity: inverse of the nominal characteristic."""
    if force >= 0:
        return _side_speed(values, at + _REBOUND, force)
    return -_side_speed(values, at + _JOUNCE, -force)


@njit(inline="always")
def _damper_temperature(layout, i, values, z, s):
    """Oil temperature of a damper law: its state, or ambient without the temperature effect."""
    if layout[i, FLAG1]:
        return z[s + layout[i, FLAG0]]
    return values[layout[i, VALUES] + _AMBIENT]


@njit(inline="always")
def _damper_force(layout, i, values, z, s, x, v):
    """DamperTruth.force (no inertia) of damper law i."""
    at = layout[i, VALUES]
    if layout[i, FLAG0]:
        total = z[s]
    else:
        temp = _damper_temperature(layout, i, values, z, s)
        total = math.exp(-values[at + _FADE] * (temp - values[at + _AMBIENT])) * _characteristic(values, at, v)
    if layout[i, FLAG2]:
        total = total - (values[at + _GAS_PRELOAD] - values[at + _GAS_RATE] * x)
    if layout[i, FLAG3]:
        total = total + values[at + _SEAL] * math.tanh(v / values[at + _FRICTION_VELOCITY])
    return total


@njit(inline="always")
def _damper_derivatives(layout, i, values, z, s, v, dz):
    """DamperTruth.derivatives of damper law i, written to dz[s:]."""
    at = layout[i, VALUES]
    temp = _damper_temperature(layout, i, values, z, s)
    scale = math.exp(-values[at + _FADE] * (temp - values[at + _AMBIENT]))
    if layout[i, FLAG0]:
        valve = z[s]
        valve_velocity = _valve_velocity(values, at, valve / scale)
        power = valve * valve_velocity
        dz[s] = values[at + _SERIES] * (v - valve_velocity)
    else:
        power = scale * _characteristic(values, at, v) * v
    if layout[i, FLAG1]:
        conducted = values[at + _HEAT_CONDUCTANCE] * (temp - values[at + _AMBIENT])
        dz[s + layout[i, FLAG0]] = (power - conducted) / values[at + _HEAT_CAPACITY]


@njit(inline="always")
def _bushing_force(layout, i, values, z, s, x):
    """BushingChannelTruth.force: progressive spring plus the Maxwell and Jenkins element forces."""
    at = layout[i, VALUES]
    total = 0.0
    for m in range(s, s + layout[i, FLAG0] + layout[i, FLAG1]):
        total += z[m]
    return values[at] * x + values[at + 1] * x**3 + total


@njit(inline="always")
def _bushing_derivatives(layout, i, values, z, s, v, dz):
    """BushingChannelTruth.derivatives: Maxwell branches relax, a Jenkins element holds while it slides outward."""
    n_maxwell, n_friction = layout[i, FLAG0], layout[i, FLAG1]
    stiffness, relaxation = layout[i, VALUES] + 2, layout[i, VALUES] + 2 + n_maxwell
    for m in range(n_maxwell):
        dz[s + m] = values[stiffness + m] * v - z[s + m] / values[relaxation + m]
    k, slip = relaxation + n_maxwell, relaxation + n_maxwell + n_friction
    for j in range(n_friction):
        f = z[s + n_maxwell + j]
        sliding_out = abs(f) >= values[slip + j] and f * v > 0
        dz[s + n_maxwell + j] = 0.0 if sliding_out else values[k + j] * v


@njit(inline="always")
def _law_forces(layout, values, z, nx, y, forces):
    """Force of every law from its states and y (deflections first, then rates, one per law)."""
    n = layout.shape[0]
    for i in range(n):
        s, x, v = nx + layout[i, STATES], y[i], y[n + i]
        if layout[i, KIND] == DAMPER:
            forces[i] = _damper_force(layout, i, values, z, s, x, v)
        elif layout[i, KIND] == BUSHING:
            forces[i] = _bushing_force(layout, i, values, z, s, x)
        else:
            forces[i] = values[layout[i, VALUES]] * x + values[layout[i, VALUES] + 1] * v


@njit(inline="always")
def _law_derivatives(layout, values, z, nx, y, dz):
    """Derivatives of every law's states, written to dz[nx:]."""
    n = layout.shape[0]
    for i in range(n):
        if layout[i, KIND] == DAMPER:
            _damper_derivatives(layout, i, values, z, nx + layout[i, STATES], y[n + i], dz)
        elif layout[i, KIND] == BUSHING:
            _bushing_derivatives(layout, i, values, z, nx + layout[i, STATES], y[n + i], dz)


@njit(inline="always")
def _row_dot(matrix, r, x):
    """Row r of a CSR matrix (indptr, indices, data) times x, summed in column order like a dense row."""
    indptr, indices, data = matrix
    total = 0.0
    for p in range(indptr[r], indptr[r + 1]):
        total += data[p] * x[indices[p]]
    return total


@njit(inline="always")
def _affine(c, x, d, u, out):
    """out = c @ x + d @ u (CSR matrices), each product summed on its own as numpy's `C @ x + D @ u` does."""
    for r in range(out.shape[0]):
        out[r] = _row_dot(c, r, x) + _row_dot(d, r, u)


@njit(inline="always")
def _spline(velocity, force, x):
    """SplineDamper at velocity x: the table, extended linearly beyond its end points."""
    if x < velocity[0]:
        return force[0] + (force[1] - force[0]) / (velocity[1] - velocity[0]) * (x - velocity[0])
    if x > velocity[-1]:
        return force[-1] + (force[-1] - force[-2]) / (velocity[-1] - velocity[-2]) * (x - velocity[-1])
    return np.interp(x, velocity, force)


@njit(cache=True)
def _rhs(vehicle, splines, laws, z, u_in, u, y, forces, g_in, g, dz):
    """dz/dt at state z with inputs u_in (force ports zero): the laws' forces close the ports, then the vehicle's
    x' = A x + B u + Bn g + f and the laws' state derivatives. u, y, forces, g_in and g are work arrays."""
    a, b, bn, cn, dn, c_sel, d_sel, f_const, force_columns = vehicle
    start, velocity, force = splines
    layout, values = laws
    nx = f_const.shape[0]
    u[:] = u_in
    _affine(c_sel, z, d_sel, u, y)
    _law_forces(layout, values, z, nx, y, forces)
    for i in range(force_columns.shape[0]):
        u[force_columns[i]] = forces[i]
    _affine(c_sel, z, d_sel, u, y)
    _affine(cn, z, dn, u, g_in)
    for i in range(g.shape[0]):
        g[i] = _spline(velocity[start[i] : start[i + 1]], force[start[i] : start[i + 1]], g_in[i])
    for r in range(nx):
        dz[r] = _row_dot(a, r, z) + _row_dot(b, r, u) + _row_dot(bn, r, g) + f_const[r]
    _law_derivatives(layout, values, z, nx, y, dz)


@njit(cache=True)
def solve(vehicle, splines, laws, z0, u_samples, substeps, h):
    """RK4 from z0 (vehicle states, then law states) over the input samples, `substeps` steps of h per sample.

    `vehicle`: A, B, Bn, Cn, Dn and the laws' rows of C and D (deflections, then rates) as CSR triples
    (indptr, indices, data), then f and the force input columns; `splines`: start, velocity, force of a
    `SplineTable`; `laws`: layout and values of a `LawTable`.

    Returns the vehicle states and the law forces at every sample, and how many samples were solved: k + 1 < n
    when the state stopped being finite on the way from sample k to k + 1.
    """
    c_sel, d_sel, f_const = vehicle[5], vehicle[6], vehicle[7]
    layout, values = laws
    nx, nz = f_const.shape[0], z0.shape[0]
    n, nu, nl = u_samples.shape[0], u_samples.shape[1], layout.shape[0]
    states = np.empty((n, nx))
    port_forces = np.empty((n, nl))
    z = z0.copy()
    u, u0, uh, u1, du = np.empty(nu), np.empty(nu), np.empty(nu), np.empty(nu), np.empty(nu)
    y, forces = np.empty(c_sel[0].shape[0] - 1), np.empty(nl)
    g_in, g = np.empty(splines[0].shape[0] - 1), np.empty(splines[0].shape[0] - 1)
    k1, k2, k3, k4, stage = np.empty(nz), np.empty(nz), np.empty(nz), np.empty(nz), np.empty(nz)
    for k in range(n):
        u[:] = u_samples[k]
        _affine(c_sel, z, d_sel, u, y)
        _law_forces(layout, values, z, nx, y, forces)
        states[k] = z[:nx]
        port_forces[k] = forces
        if k + 1 == n:
            break
        for i in range(nu):
            du[i] = (u_samples[k + 1, i] - u_samples[k, i]) / substeps
        for j in range(substeps):
            for i in range(nu):
                u0[i] = u_samples[k, i] + du[i] * j
                uh[i] = u0[i] + du[i] / 2
                u1[i] = u0[i] + du[i]
            _rhs(vehicle, splines, laws, z, u0, u, y, forces, g_in, g, k1)
            for i in range(nz):
                stage[i] = z[i] + h / 2 * k1[i]
            _rhs(vehicle, splines, laws, stage, uh, u, y, forces, g_in, g, k2)
            for i in range(nz):
                stage[i] = z[i] + h / 2 * k2[i]
            _rhs(vehicle, splines, laws, stage, uh, u, y, forces, g_in, g, k3)
            for i in range(nz):
                stage[i] = z[i] + h * k3[i]
            _rhs(vehicle, splines, laws, stage, u1, u, y, forces, g_in, g, k4)
            for i in range(nz):
                z[i] = z[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
        for i in range(nz):
            if not math.isfinite(z[i]):
                return states, port_forces, k + 1
    return states, port_forces, n
