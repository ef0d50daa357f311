"""The monolithic solver's laws and built-in spline dampers as flat arrays, the form its compiled kernel reads.

Each known law becomes one row of `LawTable.layout` (its kind, where its numbers start in `values`, where its states
start in the law state vector, and kind-specific flags or counts) and its numbers in `values`; the kernel
(`rk4_kernel`) evaluates them with the same arithmetic as the laws' own `force` and `derivatives`. Only the exact law
types below are known: a subclass may change the physics, so it is left to the generic path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.physics import BushingChannelTruth, DamperTruth, ValveSide
from nnfmu.vehicle.dynamics.builtin_elements import SplineDamper
from nnfmu.vehicle.dynamics.laws import BushingTruthLaw, ComponentLaw, DamperTruthLaw, LinearLaw

LINEAR, DAMPER, BUSHING = 0, 1, 2  # law kinds, column KIND of the layout
KIND, VALUES, STATES, FLAG0, FLAG1, FLAG2, FLAG3 = range(7)  # layout columns
# FLAG0..3 of a damper: valve-force state (hysteresis), temperature state, gas force, seal friction;
# FLAG0..1 of a bushing: Maxwell branches, Jenkins elements.


@dataclass(frozen=True)
class LawTable:
    """Laws as arrays: `layout` (n_laws, 7) int64 rows as described above, `values` float64, `initial_state` of all
    law states in law order."""

    layout: np.ndarray
    values: np.ndarray
    initial_state: np.ndarray


@dataclass(frozen=True)
class SplineTable:
    """Built-in spline dampers as arrays: law i's knots are `velocity[start[i]:start[i + 1]]` and `force[...]`."""

    start: np.ndarray
    velocity: np.ndarray
    force: np.ndarray


def _valve_side(side: ValveSide) -> list[float]:
    # The numbers ValveSide.force and .speed use: slopes, blow-off force, offset of the hyperbola, rounding.
    return [side.c_low, side.c_high, side.blow_off, side.offset, side.rounding]


def _damper(truth: DamperTruth) -> tuple[list[int], list[float]]:
    p = truth.params
    names, effects = truth.state_names, truth.effects
    flags = ["valve_force" in names, "temperature" in names, "gas_force" in effects, "seal_friction" in effects]
    values = (
        _valve_side(p.rebound)
        + _valve_side(p.jounce)
        + [
            p.series_stiffness,
            p.gas_preload,
            p.gas_rate,
            p.seal_friction,
            p.friction_velocity,
            p.heat_capacity,
            p.heat_conductance,
            p.fade,
            p.ambient_temperature,
        ]
    )
    return [int(f) for f in flags], values


def _bushing(truth: BushingChannelTruth) -> tuple[list[int], list[float]]:
    (k_maxwell, tau), (k_iwan, slip) = truth.maxwell, truth.iwan
    values = [truth.params.stiffness, truth.params.cubic_stiffness, *k_maxwell, *tau, *k_iwan, *slip]
    return [len(k_maxwell), len(k_iwan), 0, 0], [float(v) for v in values]


def _row(law: ComponentLaw) -> tuple[int, list[int], list[float]] | None:
    """(kind, flags, values) of a law the kernel knows, else None."""
    if type(law) is LinearLaw:
        return LINEAR, [0, 0, 0, 0], [law.stiffness, law.damping]
    if type(law) is DamperTruthLaw and type(law.truth) is DamperTruth:
        return DAMPER, *_damper(law.truth)
    if type(law) is BushingTruthLaw and type(law.truth) is BushingChannelTruth:
        return BUSHING, *_bushing(law.truth)
    return None


def law_table(laws: list[ComponentLaw]) -> LawTable | None:
    """The laws as a LawTable, or None if any law is of a type the compiled kernel does not know."""
    layout, values, states = [], [], []
    n_states = 0
    for law in laws:
        row = _row(law)
        if row is None:
            return None
        kind, flags, numbers = row
        layout.append([kind, len(values), n_states, *flags])
        values.extend(float(v) for v in numbers)
        states.append(np.asarray(law.initial_state(), dtype=float))
        n_states += law.n_states
    return LawTable(
        layout=np.array(layout, dtype=np.int64).reshape(len(laws), 7),
        values=np.array(values, dtype=float),
        initial_state=np.concatenate(states) if states else np.zeros(0),
    )


def spline_table(splines: list[SplineDamper]) -> SplineTable:
    """The vehicle's built-in spline dampers as a SplineTable."""
    lengths = [len(s.velocity) for s in splines]
    return SplineTable(
        start=np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        velocity=np.array([v for s in splines for v in s.velocity], dtype=float),
        force=np.array([f for s in splines for f in s.force], dtype=float),
    )
