"""The dyno's moving mass estimated from a damper record, with its 95 % confidence interval.

A damper dyno's load cell reads F = F_v + F_s + F_g + m·a: the valve force, the seal friction F_s = F_c·tanh(v/v_s),
the gas force F_g = g_0 + g_1·x and the mass m of rod, piston and fixture moving between load cell and actuator
(`inertia`). A regression of F on functions of the velocity and on a cannot find m: the valve force lags the stroke
through the oil and gas column's compliance, and a lag puts a force proportional to a into F as well (for a series
stiffness k, -c'(v)²/k·a: tens of kg at a passenger damper's bleed slope). The valve's own equation tells them apart:
with a series stiffness, the valve sees the velocity v - Ḟ_v/k, so

    v = w(F_v) + Ḟ_v / k,    F_v = F - m·a - F_s(v) - F_g(x),

where w is the valve's inverse characteristic (any smooth curve: a cubic spline in F_v with KNOTS interior knots at
the quantiles of F_v). For given (m, F_c, g_0, g_1) the equation is linear in the spline's coefficients and 1/k;
Gauss-Newton on the velocity residual finds the four (at most ITERATIONS steps, until m moves by less than
TOLERANCE kg). The confidence interval is a block jackknife over BLOCKS contiguous parts of the record (so it carries
the residual's correlation in time and how well the model fits each part, not only the sensor noise), widened by
BIAS kg: the transducers' noise sits inside the regressors (F_v, Ḟ_v, a and its rate come from the noisy force and
velocity), which biases the fit. On the dyno simulator's 40 s lab records (`nnfmu rig damper`: hysteresis, seal
friction; seed 3) the fit without the widening gives -0.006 ± 0.004 kg without a fixture on exact signals and
-0.028 ± 0.010 kg at the rig's default noise (10 N, 2 mm/s rms), and 1.98 ± 0.02 kg for a 2 kg fixture; BIAS
covers that shift.

The estimate says how much of the force is m·a: `MassEstimate.share`, the m·a rms over the force rms. Where the
interval excludes 0 the mass is there to take out (`MassEstimate.found`): a network trained on the raw force adds it
to the car's unsprung mass a second time (2 kg on a passenger damper's dyno record: 4-5 % of the force rms).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline

from nnfmu.data.derive import derivative
from nnfmu.data.errors import DataError
from nnfmu.data.inertia import stroke_acceleration
from nnfmu.data.measurement import Measurement

KNOTS = 16  # interior knots of the valve's inverse characteristic
FRICTION_VELOCITY = 0.002  # m/s: velocity scale v_s of the seal friction's tanh
ITERATIONS = 12
TOLERANCE = 1e-4  # kg
BLOCKS = 10  # parts of the record for the jackknife
Z95 = 1.959964  # two-sided 95 % normal quantile
BIAS = 0.03  # kg added to the interval's half-width for the bias the transducers' noise leaves (docstring)
ROWS = 1 << 15  # rows of the fit's design built at a time (about 6 MB): its normal equations are summed by parts


@dataclass(frozen=True)
class MassEstimate:
    """The moving mass [kg] and its 95 % half-width [kg], m·a's share of the force rms, the fitted series stiffness
    [N/m] (inf: no lag seen) and where the acceleration came from."""

    mass: float
    half_width: float
    share: float
    stiffness: float
    acceleration: str

    @property
    def found(self) -> bool:
        """True when the 95 % interval excludes 0 kg: a mass to take out of the force."""
        return self.mass - self.half_width > 0.0

    def describe(self) -> str:
        """One line for a `note:`."""
        lag = f"{self.stiffness:.3g} N/m" if math.isfinite(self.stiffness) else "none seen"
        return (
            f"moving mass between load cell and actuator estimated from the record: {self.mass:.3g} ± "
            f"{self.half_width:.2g} kg (95 %), its m·a {self.share:.2%} of the force rms (valve characteristic "
            f"behind a series stiffness, {lag}, seal friction and gas force fitted beside it; a from "
            f"{self.acceleration})"
        )


Rows = Callable[[int, int], np.ndarray]  # rows lo..hi-1 of a design matrix, built on demand


def _knots(g: np.ndarray, source: str) -> np.ndarray:
    """Knot vector of the cubic B-spline in `g` (KNOTS interior knots at its quantiles); DataError if g is constant."""
    inner = np.unique(np.quantile(g, np.linspace(0.0, 1.0, KNOTS + 2)[1:-1]))
    lo, hi = float(np.min(g)), float(np.max(g))
    if not hi > lo or inner.size < 2:
        raise DataError(f"{source}: the force does not vary enough to fit the valve characteristic")
    return np.r_[[lo] * 4, inner[(inner > lo) & (inner < hi)], [hi] * 4]


def _basis(g: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Cubic B-spline design matrix of `g` on `knots`, shape (len(g), len(knots) - 4)."""
    return BSpline.design_matrix(np.clip(g, knots[0], knots[-1]), knots, 3).toarray()


def _normal_equations(rows: Rows, y: np.ndarray, edges: Sequence[int]) -> list[tuple[np.ndarray, np.ndarray]]:
    """(x.T x, x.T y) of each part edges[i]..edges[i+1]-1 of the design `rows` and target `y`, summed ROWS rows at
    a time, so the design (tens of columns of the record's length) is never held whole."""
    parts = []
    for first, last in zip(edges[:-1], edges[1:]):
        gram, moment = 0.0, 0.0
        for lo in range(first, last, ROWS):
            hi = min(last, lo + ROWS)
            x = rows(lo, hi)
            gram, moment = gram + x.T @ x, moment + x.T @ y[lo:hi]
        parts.append((gram, moment))
    return parts


def _solve(gram: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """Least-squares coefficients from the normal equations (x.T x, x.T y) of a tall x, its columns scaled to unit
    norm first (the Gram's diagonal)."""
    scale = np.sqrt(np.diag(gram)).copy()
    scale[scale == 0.0] = 1.0
    return np.linalg.lstsq(gram / np.outer(scale, scale), moment / scale, rcond=None)[0] / scale


def _jackknife(parts: list[tuple[np.ndarray, np.ndarray]], column: int) -> float:
    """Standard error of coefficient `column` of the least-squares fit by a delete-a-block jackknife over the
    blocks' normal equations `parts`."""
    gram = sum(p[0] for p in parts)
    moment = sum(p[1] for p in parts)
    estimates = [np.linalg.lstsq(gram - g, moment - b, rcond=None)[0][column] for g, b in parts]
    spread = np.asarray(estimates)
    return float(np.sqrt((BLOCKS - 1) / BLOCKS * np.sum((spread - spread.mean()) ** 2)))


def estimate_moving_mass(m: Measurement, force: str = "force") -> MassEstimate:
    """The moving mass in `m`'s `force` [N] (module docstring); DataError naming the source when it cannot be fitted
    (no velocity [m/s], no displacement [m], or a force that does not vary)."""
    for name, unit in ((force, "N"), ("velocity", "m/s"), ("displacement", "m")):
        if name not in m.channels or m.units[name] != unit:
            raise DataError(f"{m.source}: estimating the moving mass needs a {name!r} channel in {unit}")
    f, v, x = m[force], m["velocity"], m["displacement"]
    a, source = stroke_acceleration(m)
    dt = m.sample_period
    jerk, f_rate = derivative(a, dt, 1), derivative(f, dt, 1)
    s = np.tanh(v / FRICTION_VELOCITY)
    ones, zeros = np.ones_like(f), np.zeros_like(f)
    # (dG/dθ, dĠ/dθ) for θ = (m, F_c, g_0, g_1): G = F - m·a - F_c·s - g_0 - g_1·x; the friction's own rate is left
    # out of Ġ: it moves only at reversals, where the velocity's noise makes its sign a coin toss
    partials = ((a, jerk), (s, zeros), (ones, zeros), (x, v))
    theta = np.zeros(4)
    whole = [0, f.size]
    for _ in range(ITERATIONS):
        g = f - theta[0] * a - theta[1] * s - theta[2] - theta[3] * x
        g_rate = f_rate - theta[0] * jerk - theta[3] * v
        knots = _knots(g, m.source)

        def base(lo: int, hi: int, g: np.ndarray = g, g_rate: np.ndarray = g_rate, knots: np.ndarray = knots):
            return np.column_stack([_basis(g[lo:hi], knots), g_rate[lo:hi]])

        coef = _solve(*_normal_equations(base, v, whole)[0])
        slope = BSpline(knots, coef[:-1], 3).derivative()

        def design(lo: int, hi: int, base=base, slope=slope, g=g, knots=knots, rate=coef[-1]) -> np.ndarray:
            k = slope(np.clip(g[lo:hi], knots[0], knots[-1]))
            return np.column_stack([base(lo, hi), *(-(k * dg[lo:hi] + rate * dr[lo:hi]) for dg, dr in partials)])

        columns = knots.size - 4 + 1
        full = _solve(*_normal_equations(design, v, whole)[0])
        theta = theta + full[columns:]
        if not np.all(np.isfinite(theta)):
            raise DataError(f"{m.source}: the moving-mass fit did not converge")
        if abs(full[columns]) < TOLERANCE:
            break
    edges = np.linspace(0, v.size, BLOCKS + 1).astype(int)
    error = _jackknife(_normal_equations(design, v, list(edges)), columns)
    rms = float(np.sqrt(np.mean(f**2)))
    share = abs(theta[0]) * float(np.sqrt(np.mean(a**2))) / rms if rms > 0 else 0.0
    stiffness = 1.0 / coef[-1] if coef[-1] > 0 else math.inf
    return MassEstimate(float(theta[0]), Z95 * error + BIAS, share, float(stiffness), source)
