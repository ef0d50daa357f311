"""Per-step reference elements of the stabilised force ports: the component's local stiffness and damping, given each
step, in place of the element fitted once.

A stabilised port applies over a step from x_k the force set at the step start plus its reference element's change,
k0 (d(x) - d_k) + c0 (r(x) - r_k), d and r the port's deflection and its rate (`nnfmu.vehicle.dynamics.linear`). The
exact step is built on k0 and c0. Given the component's local stiffness k and damping c at the step start (a
master takes them from the component FMU's directional derivatives), the port applies k and c instead: the
difference dk = k - k0, dc = c - c0 adds the force e(t) = dk (d(x) - d_k) + dc (r(x) - r_k), which the step takes
as a ramp from 0 to its end value e over the step, x_end = x_exact + R e (R: the stabilised vehicle's response at
the step end to a unit force ramp on each port). With x_end in e, (I - G R) e = G (x_exact - x_k), G = dk P_d +
dc P_r; the step solves it by one Jacobi sweep and one refinement on the diagonal 1 - (G R)_jj, so a stiffer
channel (dk > 0: the diagonal above 1) is taken implicitly.

Guards (passive range): k and c below 0 count as 0 (so dk >= -k0, dc >= -c0), and the diagonal is kept at or above
`MIN_DIAGONAL`: a channel much softer than its fitted element moves at most 1 / MIN_DIAGONAL times what the exact
step predicts. Non-finite values never reach the vehicle (the FMU refuses them; the master keeps the last finite
ones). With dk = dc = 0 the correction is exactly 0: the state is bit for bit that of the fitted elements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.vehicle.dynamics.linear import ramp_integral

MIN_DIAGONAL = 0.5  # 1 - (G R)_jj is kept at or above this (at most twice the exact step's motion per channel)


@dataclass(frozen=True)
class GainCorrection:
    """Constants of the correction for the stabilised ports `ports` (input indices) of a step of `dt` [s]:
    `fitted` (ns, 2) their (k0, c0); `deflection` and `rate` (ns, nx) the rows P_d, P_r; `ramp` (nx, ns) R;
    `deflection_ramp`, `rate_ramp` (ns, ns) P_d R and P_r R."""

    ports: np.ndarray
    fitted: np.ndarray
    deflection: np.ndarray
    rate: np.ndarray
    ramp: np.ndarray
    deflection_ramp: np.ndarray
    rate_ramp: np.ndarray

    def changes(self, stiffness: np.ndarray, damping: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(dk, dc) per port from the given local stiffness and damping, clamped to the passive range (>= 0)."""
        return np.maximum(stiffness, 0.0) - self.fitted[:, 0], np.maximum(damping, 0.0) - self.fitted[:, 1]

    def correct(self, x_start: np.ndarray, x_exact: np.ndarray, dk: np.ndarray, dc: np.ndarray) -> np.ndarray:
        """The state at the step end with the ports' elements changed by (dk, dc), from the state `x_exact` the step
        on the fitted elements reached from `x_start` (the graph's arithmetic, in numpy)."""
        moved = x_exact - x_start
        pulled = dk * (self.deflection @ moved) + dc * (self.rate @ moved)
        diagonal = 1.0 - (dk * np.diag(self.deflection_ramp) + dc * np.diag(self.rate_ramp))
        diagonal = MIN_DIAGONAL + np.maximum(diagonal - MIN_DIAGONAL, 0.0)
        first = pulled / diagonal
        off_d = self.deflection_ramp - np.diag(np.diag(self.deflection_ramp))
        off_r = self.rate_ramp - np.diag(np.diag(self.rate_ramp))
        force = (pulled + dk * (off_d @ first) + dc * (off_r @ first)) / diagonal
        return x_exact + self.ramp @ force


def gain_correction(a: np.ndarray, b: np.ndarray, rows: np.ndarray, elements: np.ndarray, dt: float) -> GainCorrection:
    """The correction of a step of `dt` [s] for the state matrix `a` (stabilised, nx x nx), inputs `b` (nx, nu), the
    ports' deflection rows `rows` (nu, nx / 2; zero rows: not stabilised) and their elements (nu, 2)."""
    ports = np.flatnonzero(np.any(rows != 0.0, axis=1))
    n = rows.shape[1]
    deflection = np.hstack([rows[ports], np.zeros((len(ports), n))])
    rate = np.hstack([np.zeros((len(ports), n)), rows[ports]])
    ramp = ramp_integral(a, b[:, ports], dt) / dt  # the state at dt under inputs ramping from 0 to 1
    return GainCorrection(ports, elements[ports], deflection, rate, ramp, deflection @ ramp, rate @ ramp)
