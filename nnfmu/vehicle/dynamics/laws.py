"""Force laws that close a vehicle's component ports in the monolithic reference: linear, or the rigs' truth physics.

A law maps one deflection x and its rate v (plus its own states) to the force or torque the component carries; its
states follow `derivatives`. The rig simulators' truth models (`nnfmu.data.rigs`) fit this shape, so the vehicle can
be solved with the very physics the component networks were trained on.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from nnfmu.kinds import kind_of
from nnfmu.physics import DEFAULT_EFFECTS, BushingChannelTruth, BushingParams, DamperParams, DamperTruth
from nnfmu.vehicle.dynamics.errors import VehicleModelError
from nnfmu.vehicle.dynamics.ports import component_channels


class ComponentLaw(Protocol):
    """Force from one deflection and its rate, with internal states (hysteresis, temperature, friction)."""

    @property
    def n_states(self) -> int: ...

    def initial_state(self) -> np.ndarray: ...

    def derivatives(self, t: float, state: np.ndarray, x: float, v: float) -> np.ndarray: ...

    def force(self, state: np.ndarray, x: float, v: float) -> float: ...


@dataclass(frozen=True)
class LinearLaw:
    """force = stiffness * x + damping * v, no states (the linear reference element)."""

    stiffness: float
    damping: float
    n_states: int = 0

    def initial_state(self) -> np.ndarray:
        return np.zeros(0)

    def derivatives(self, t: float, state: np.ndarray, x: float, v: float) -> np.ndarray:
        return np.zeros(0)

    def force(self, state: np.ndarray, x: float, v: float) -> float:
        return self.stiffness * x + self.damping * v


class _TruthStates:
    """State handling of the truth laws: the rig's truth model owns the states and their derivatives."""

    truth: DamperTruth | BushingChannelTruth

    @property
    def n_states(self) -> int:
        return self.truth.n_states

    def initial_state(self) -> np.ndarray:
        return self.truth.initial_state()

    def derivatives(self, t: float, state: np.ndarray, x: float, v: float) -> np.ndarray:
        return self.truth.derivatives(t, state, x, v)


@dataclass(frozen=True)
class DamperTruthLaw(_TruthStates):
    """The damper dyno's truth physics (tension positive). Its moving-mass effect is refused: in the vehicle that mass
    is part of the unsprung mass already."""

    truth: DamperTruth

    def __post_init__(self) -> None:
        if "inertia" in self.truth.effects:
            raise VehicleModelError(
                "damper truth law: drop the 'inertia' effect; the vehicle's unsprung mass carries it"
            )

    def force(self, state: np.ndarray, x: float, v: float) -> float:
        return float(self.truth.force(state, x, v, 0.0))


@dataclass(frozen=True)
class BushingTruthLaw(_TruthStates):
    """One channel of the bushing rig's truth physics (N or N.m)."""

    truth: BushingChannelTruth

    def force(self, state: np.ndarray, x: float, v: float) -> float:
        return float(self.truth.force(state, x))


class BushingTruthBank:
    """Bushing truth laws with the same state layout evaluated together on arrays (one row per law): the monolithic
    solver calls the laws at every RK4 stage, and per-law numpy calls on a handful of states would dominate it.
    Same arithmetic as `BushingChannelTruth.derivatives` and `force`, row by row."""

    def __init__(self, laws: list[BushingTruthLaw]) -> None:
        truths = [law.truth for law in laws]
        layout = {(t.n_maxwell, t.n_friction) for t in truths}
        if len(layout) != 1:
            raise VehicleModelError(f"bushing laws in one bank need one state layout, got {sorted(layout)}")
        self.n_maxwell, self.n_friction = layout.pop()
        self.size = len(truths)
        self.linear = np.array([t.params.stiffness for t in truths])
        self.cubic = np.array([t.params.cubic_stiffness for t in truths])
        self.maxwell_stiffness = np.array([t.maxwell[0] for t in truths]).reshape(self.size, self.n_maxwell)
        self.maxwell_time = np.array([t.maxwell[1] for t in truths]).reshape(self.size, self.n_maxwell)
        self.iwan_stiffness = np.array([t.iwan[0] for t in truths]).reshape(self.size, self.n_friction)
        self.iwan_slip = np.array([t.iwan[1] for t in truths]).reshape(self.size, self.n_friction)

    @property
    def n_states(self) -> int:
        return self.size * (self.n_maxwell + self.n_friction)

    def initial_state(self) -> np.ndarray:
        return np.zeros(self.n_states)

    def derivatives(self, t: float, state: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        rows = state.reshape(self.size, -1)
        z, f = rows[:, : self.n_maxwell], rows[:, self.n_maxwell :]
        rate = v[:, None]
        dz = self.maxwell_stiffness * rate - z / self.maxwell_time
        df = np.where((np.abs(f) >= self.iwan_slip) & (f * rate > 0), 0.0, self.iwan_stiffness * rate)
        return np.hstack([dz, df]).ravel()

    def forces(self, state: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.linear * x + self.cubic * x**3 + state.reshape(self.size, -1).sum(axis=1)


def truth_laws(force_inputs: list[str]) -> dict[str, ComponentLaw]:
    """Default truth physics for every damper and bushing force input in `force_inputs` (rig defaults, no inertia);
    the law is chosen by the port's kind (`nnfmu.kinds`) from `_TRUTH`."""
    laws: dict[str, ComponentLaw] = {}
    for name in force_inputs:
        kind = kind_of(name)
        element = kind.element_of_port(name) if kind is not None else None
        make = _TRUTH.get(kind.name) if kind is not None else None
        law = make(name[len(element) + 1 :]) if make is not None and element is not None else None
        if law is None:
            raise VehicleModelError(f"no truth physics for port {name!r}")
        laws[name] = law
    return laws


def _damper_truth(channel: str) -> ComponentLaw:
    """The dyno damper's default truth, without the inertia the vehicle's own masses carry."""
    return DamperTruthLaw(DamperTruth(DamperParams(), tuple(e for e in DEFAULT_EFFECTS["damper"] if e != "inertia")))


def _bushing_truth(channel: str) -> ComponentLaw | None:
    """The rig bushing's default truth of one channel (`axial_force`, ...); None for another channel."""
    bushing = BushingParams()
    params = {
        "axial_force": bushing.axial,
        "radial_force": bushing.radial,
        "axial_torque": bushing.axial_rotation,
        "conical_torque": bushing.conical_rotation,
    }.get(channel)
    return BushingTruthLaw(BushingChannelTruth(params)) if params is not None else None


# Truth law per component kind (a kind's name in `nnfmu.kinds`), given the force channel of its port.
_TRUTH: dict[str, Callable[[str], ComponentLaw | None]] = {"damper": _damper_truth, "bushing": _bushing_truth}


def linear_laws(component: str, stiffness: tuple[float, ...], damping: tuple[float, ...]) -> dict[str, ComponentLaw]:
    """LinearLaw per channel of `component` (one value per channel, in port order)."""
    channels = component_channels(component)
    if not (len(stiffness) == len(damping) == len(channels)):
        raise VehicleModelError(f"{component}: needs {len(channels)} stiffness and damping values")
    return {force: LinearLaw(k, c) for (force, _, _), k, c in zip(channels, stiffness, damping)}
