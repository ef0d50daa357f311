"""Truth physics of a rubber bushing, one channel at a time: progressive spring, Maxwell branches, Berg friction.

F = k1·x + k3·x³ (always) + Σ z_i (viscoelastic: generalised Maxwell, z_i' = k_i v - z_i/τ_i) + friction.
The friction follows Berg's virgin curve F_f = F_max·d/(x2 + d) (Berg 1998, "A non-linear rubber spring model for
rail vehicle dynamics analysis", Vehicle System Dynamics 30) realised as parallel Jenkins elements (Iwan 1966),
which reverse by Masing's rule like Berg's model, with one continuous state per element instead of stored
reversal points. Translational channels use m and N, rotational channels rad and N.m.

Parameter ranges (front lower-control-arm bushing of a mid-size car): radial 3-8 kN/mm, axial 0.5-1.5 kN/mm,
torsional ~5-20 N.m/deg, conical ~30-100 N.m/deg; dynamic-to-static stiffness ratio ~1.1-1.5 and loss angles of a
few degrees for filled natural rubber (Kari, Dzierzek; Sjöberg 2002 thesis on rubber isolators).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from nnfmu.errors import SettingsError
from nnfmu.physics.effects import BUSHING_EFFECTS, DEFAULT_EFFECTS

IWAN_ELEMENTS = 12  # Jenkins elements approximating Berg's friction curve
IWAN_SPAN = (0.05, 30.0)  # slip displacements of the first and last element, in units of x2; the last slips at F_max


@dataclass(frozen=True)
class BushingChannelParams:
    """One channel: position in `position_unit` (m or rad), force in `force_unit` (N or N.m)."""

    stiffness: float
    cubic_stiffness: float
    maxwell_stiffness: tuple[float, ...]
    maxwell_time: tuple[float, ...]
    friction_max: float
    friction_x2: float
    position_unit: str = "m"
    force_unit: str = "N"

    def __post_init__(self) -> None:
        if len(self.maxwell_stiffness) != len(self.maxwell_time) or min(self.maxwell_time, default=1.0) <= 0:
            raise SettingsError(f"each Maxwell branch needs a stiffness and a positive time constant; got {self}")
        if not (self.friction_max > 0 and self.friction_x2 > 0):
            raise SettingsError(f"Berg friction needs friction_max > 0 and friction_x2 > 0; got {self}")

    def describe(self) -> dict:
        pos, frc = self.position_unit, self.force_unit
        rows = {
            "stiffness": (self.stiffness, f"{frc}/{pos}", "linear elastic stiffness k1"),
            "cubic_stiffness": (self.cubic_stiffness, f"{frc}/{pos}^3", "progressive term k3 (F = k1 x + k3 x^3)"),
            "maxwell_stiffness": (list(self.maxwell_stiffness), f"{frc}/{pos}", "stiffness k_i of each Maxwell branch"),
            "maxwell_time": (list(self.maxwell_time), "s", "relaxation time tau_i of each Maxwell branch"),
            "friction_max": (self.friction_max, frc, "Berg friction: maximum friction force F_max"),
            "friction_x2": (self.friction_x2, pos, "Berg friction: displacement to reach F_max/2 from zero"),
        }
        return {k: {"value": v, "unit": u, "doc": d} for k, (v, u, d) in rows.items()}


def _translational(**kw) -> BushingChannelParams:
    return BushingChannelParams(position_unit="m", force_unit="N", **kw)


def _rotational(**kw) -> BushingChannelParams:
    return BushingChannelParams(position_unit="rad", force_unit="N.m", **kw)


@dataclass(frozen=True)
class BushingParams:
    """Front lower-control-arm bushing; cubic terms add ~50-60 % stiffness at the edge of the vehicle range."""

    axial: BushingChannelParams = _translational(
        stiffness=1.0e6,
        cubic_stiffness=5.6e10,
        maxwell_stiffness=(1.2e5, 1.0e5, 0.8e5),
        maxwell_time=(0.002, 0.015, 0.1),
        friction_max=50.0,
        friction_x2=2e-4,
    )
    radial: BushingChannelParams = _translational(
        stiffness=5.0e6,
        cubic_stiffness=1.33e12,
        maxwell_stiffness=(6e5, 5e5, 4e5),
        maxwell_time=(0.002, 0.015, 0.1),
        friction_max=200.0,
        friction_x2=1e-4,
    )
    axial_rotation: BushingChannelParams = _rotational(
        stiffness=573.0,
        cubic_stiffness=1.27e4,
        maxwell_stiffness=(100.0, 80.0, 60.0),
        maxwell_time=(0.002, 0.015, 0.1),
        friction_max=3.0,
        friction_x2=0.005,
    )
    conical_rotation: BushingChannelParams = _rotational(
        stiffness=2865.0,
        cubic_stiffness=5.7e5,
        maxwell_stiffness=(500.0, 400.0, 300.0),
        maxwell_time=(0.002, 0.015, 0.1),
        friction_max=10.0,
        friction_x2=0.002,
    )


def iwan_elements(friction_max: float, x2: float) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and slip force of IWAN_ELEMENTS Jenkins elements whose joint virgin curve interpolates Berg's
    F_max·d/(x2 + d) at geometrically spaced slip displacements, the last reaching F_max."""
    slip = x2 * np.geomspace(*IWAN_SPAN, IWAN_ELEMENTS)
    virgin = friction_max * slip / (x2 + slip)
    virgin[-1] = friction_max
    tangent = np.diff(np.concatenate([[0.0], virgin])) / np.diff(np.concatenate([[0.0], slip]))
    stiffness = tangent - np.concatenate([tangent[1:], [0.0]])
    return stiffness, stiffness * slip


@dataclass(frozen=True)
class BushingChannelTruth:
    """Force (or torque) of one bushing channel from its state and the prescribed position.

    States (those of the switched-on effects, in order): Maxwell branch forces z_i, then Jenkins element forces f_j.
    `maxwell` (stiffness, relaxation time) and `iwan` (stiffness, slip force) hold the switched-on elements' arrays.
    """

    params: BushingChannelParams
    effects: tuple[str, ...] = DEFAULT_EFFECTS["bushing"]
    iwan: tuple[np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)
    maxwell: tuple[np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        unknown = [e for e in self.effects if e not in BUSHING_EFFECTS]
        if unknown:
            raise SettingsError(f"unknown bushing effect(s) {unknown}; valid: {', '.join(BUSHING_EFFECTS)}")
        k, slip = iwan_elements(self.params.friction_max, self.params.friction_x2)
        object.__setattr__(self, "iwan", (k[: self.n_friction], slip[: self.n_friction]))
        maxwell = (
            np.asarray(self.params.maxwell_stiffness[: self.n_maxwell], dtype=float),
            np.asarray(self.params.maxwell_time[: self.n_maxwell], dtype=float),
        )
        object.__setattr__(self, "maxwell", maxwell)  # per-call arrays would dominate a solver's right-hand side

    @property
    def n_maxwell(self) -> int:
        return len(self.params.maxwell_stiffness) if "viscoelastic" in self.effects else 0

    @property
    def n_friction(self) -> int:
        return IWAN_ELEMENTS if "friction" in self.effects else 0

    @property
    def n_states(self) -> int:
        return self.n_maxwell + self.n_friction

    def initial_state(self) -> np.ndarray:
        """A relaxed bushing: no branch or friction force."""
        return np.zeros(self.n_states)

    def elastic_force(self, x):
        """Progressive elastic force k1·x + k3·x³."""
        x = np.asarray(x, dtype=float)
        return self.params.stiffness * x + self.params.cubic_stiffness * x**3

    def derivatives(self, t: float, state: np.ndarray, x: float, v: float) -> np.ndarray:
        """d(state)/dt at time t [s] for position x and rate v; a Jenkins element holds while it slides outward."""
        stiffness, relaxation = self.maxwell
        z, f = state[: len(stiffness)], state[len(stiffness) :]
        dz = stiffness * v - z / relaxation
        k, slip = self.iwan
        df = np.where((np.abs(f) >= slip) & (f * v > 0), 0.0, k * v)
        return np.concatenate([dz, df])

    def force(self, state, x):
        """Force for state(s) of shape (n_states,) or (n, n_states) and position(s) x; the rate acts through the
        states only."""
        state = np.asarray(state, dtype=float)
        return self.elastic_force(x) + state.sum(axis=-1)

    def simulate(self, dt: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Force and states (shape (n, n_states)) along a position sampled every `dt` [s], linear between samples.

        Exact for that input: Maxwell branches as first-order recursions with the exact exponential, Jenkins
        elements as play operators (clip after each increment).
        """
        x = np.asarray(x, dtype=float)
        dx = np.diff(x, prepend=x[0])
        columns = []
        for k, tau in zip(self.params.maxwell_stiffness[: self.n_maxwell], self.params.maxwell_time):
            decay = math.exp(-dt / tau)
            gain = k * tau * (1 - decay) / dt
            columns.append(lfilter([gain], [1.0, -decay], dx))
        if self.n_friction:
            k, slip = self.iwan
            f = np.zeros(IWAN_ELEMENTS)
            friction = np.empty((len(x), IWAN_ELEMENTS))
            for i, step in enumerate(dx):
                f = np.minimum(np.maximum(f + k * step, -slip), slip)
                friction[i] = f
            columns.extend(friction.T)
        states = np.column_stack(columns) if columns else np.empty((len(x), 0))
        return self.force(states, x), states
