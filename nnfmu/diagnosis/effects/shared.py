"""The effect library: each physical effect a model may lack is a family of candidate regressors computed from the
measured channels (and the model's own prediction, for effects that scale or delay its force), under a stable name.

A family names the channels it needs (`requires`, base names; rates the rig did not measure are derived first); where
it falls back on a proxy, its regressors name the channel that would measure the effect directly
(`Regressors.missing`): temperature without a temperature channel uses the dissipated energy ∫F·v dt, which drives
the oil's heating.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from .errors import DiagnosisError
from .settings import DiagnosisSettings
from .signals import EffectSignals


@dataclass(frozen=True)
class Regressors:
    """Columns of one family, shape (n, k), their names, the channels a direct measurement would need, and how."""

    names: tuple[str, ...]
    matrix: np.ndarray
    missing: tuple[str, ...]
    note: str


@dataclass(frozen=True)
class EffectFamily:
    """One physical effect: what it is, the channels it needs, and how its regressors are computed."""

    name: str
    description: str
    requires: tuple[str, ...]
    compute: Callable[[EffectSignals, DiagnosisSettings], Regressors]

    def missing(self, signals: EffectSignals) -> tuple[str, ...]:
        """The required base channels that `signals` lacks (the family cannot be tested without them)."""
        return tuple(name for name in self.requires if not signals.has(name))


CENTRED = (
    "; centred on its record mean, so that only its variation counts as evidence (a constant level times the "
    "prediction is a plain gain error of the model, which no effect can be told from)"
)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _low_pass(x: np.ndarray, time_constant: float, dt: float, initial: float | None = None) -> np.ndarray:
    """First-order low-pass (exact discretisation of 1/(τs+1)), started in steady state at `initial` (default x[0])."""
    a = float(np.exp(-dt / time_constant))
    start = x[0] if initial is None else initial
    filtered, _ = lfilter([1 - a], [1, -a], x, zi=[a * start])
    return filtered


def _delayed(x: np.ndarray, samples: int) -> np.ndarray:
    """x(t - samples·dt), holding the first value before the record starts."""
    samples = min(samples, len(x) - 1)
    return np.concatenate([np.full(samples, x[0]), x[:-samples]])


def _derived_note(s: EffectSignals, base: str) -> str:
    return f" ({base} derived: {s.derived[base]})" if base in s.derived else ""


def _seal_friction(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    v = s["velocity"]
    scales = [fraction * (_rms(v) or 1.0) for fraction in settings.friction_scales]
    columns = [np.tanh(v / scale) for scale in scales]
    names = tuple(f"tanh(velocity / {scale:.3g} m/s)" for scale in scales)
    note = "smoothed sign of velocity (Coulomb friction) at velocity scales " + ", ".join(f"{x:.3g}" for x in scales)
    return Regressors(names, np.column_stack(columns), (), note + " m/s" + _derived_note(s, "velocity"))


def _gas_force(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    x = s["displacement"]
    matrix = np.column_stack([np.ones_like(x), x])
    note = "preload (constant) and spring rate (displacement); the constant alone cannot be told from a sensor offset"
    return Regressors(("1 (preload)", "displacement [m]"), matrix, (), note + _derived_note(s, "displacement"))


def _reversal_travel(v: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(direction ±1, travel [m] since the last reversal) of every sample. A reversal is a velocity sign change
    beyond ±2 % of the rms velocity, so noise about zero velocity does not flip the direction. Before the first
    reversal the travel is unknown and taken as infinite (no build-up is claimed at the record's start)."""
    threshold = 0.02 * _rms(v)
    direction = np.empty_like(v)
    travel = np.empty_like(v)
    state, distance = (1.0 if v[0] >= 0 else -1.0), np.inf
    for i, value in enumerate(v):
        if value * state < -threshold:
            state, distance = -state, 0.0
        distance += abs(value) * dt
        direction[i], travel[i] = state, distance
    return direction, travel


def mean_stroke(v: np.ndarray, dt: float) -> float:
    """Mean travel [m] between motion reversals of the velocity `v` (the whole travel when it never reverses)."""
    direction, travel = _reversal_travel(v, dt)
    ends = np.nonzero(np.diff(direction))[0]
    finite = travel[ends][np.isfinite(travel[ends])]
    return float(np.mean(finite)) if finite.size else float(np.sum(np.abs(v)) * dt)


def _hysteresis(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    dt = s.sample_period
    delays = sorted({max(1, int(round(delay / dt))) for delay in settings.memory_delays})
    columns = [_delayed(s.predicted, d) - s.predicted for d in delays]
    names = [f"predicted {s.output} delayed {d * dt * 1e3:.3g} ms - predicted {s.output}" for d in delays]
    direction, travel = _reversal_travel(s["velocity"], dt)
    stroke = mean_stroke(s["velocity"], dt)
    for fraction in settings.reversal_fractions:
        length = fraction * stroke if stroke > 0 else 1.0
        columns.append(direction * np.exp(-travel / length))
        names.append(f"sign(velocity)*exp(-travel since reversal / {length:.3g} m)")
    note = (
        "memory: the model's force delayed (compliance lag) and the force build-up over the travel after a motion "
        f"reversal (Dahl-like, backlash), at {', '.join(f'{f:g}' for f in settings.reversal_fractions)} of the "
        f"mean travel between reversals ({stroke:.3g} m)"
    )
    return Regressors(tuple(names), np.column_stack(columns), (), note + _derived_note(s, "velocity"))


def stop_operator(x: np.ndarray, radius: float) -> np.ndarray:
    """x minus its play-operator output at half-width `radius`, the driven side starting at x[0] - clipped to
    [-radius, radius]: where the driving side sits in a backlash gap (±radius: in contact)."""
    play = float(x[0])
    out = np.empty(len(x))
    for k, value in enumerate(np.asarray(x, dtype=float).tolist()):
        play = min(max(play, value - radius), value + radius)
        out[k] = value - play
    return out


def backlash_radii(v: np.ndarray, dt: float, fractions: tuple[float, ...]) -> tuple[float, ...]:
    """Half-widths [m] of the backlash gaps tried: each fraction of the mean travel between reversals is the travel
    over which that gap closes after a reversal (2 × radius)."""
    stroke = mean_stroke(v, dt)
    return tuple(0.5 * fraction * (stroke if stroke > 0 else 1.0) for fraction in fractions)


def _backlash(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    radii = backlash_radii(s["velocity"], s.sample_period, settings.reversal_fractions)
    columns = [stop_operator(s["displacement"], r) for r in radii]
    names = tuple(f"stop(displacement, radius={r:.3g} m)" for r in radii)
    fractions = ", ".join(f"{f:g}" for f in settings.reversal_fractions)
    note = (
        "backlash (play) at motion reversals: the displacement's stop operators (position inside a gap of half-width "
        f"{', '.join(f'{r:.3g}' for r in radii)} m, closed after {fractions} of the mean travel between reversals), "
        "a Prandtl-Ishlinskii bank"
    )
    return Regressors(names, np.column_stack(columns), (), note + _derived_note(s, "displacement"))


def _inertia(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    a = s["acceleration"]
    note = "mass times acceleration" + _derived_note(s, "acceleration")
    return Regressors(("acceleration [m/s^2]",), a[:, None], (), note)


def _temperature(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    if s.has("temperature"):
        change = s["temperature"] - np.mean(s["temperature"])
        names = ("temperature - its mean [K]", f"(temperature - its mean) * predicted {s.output}")
        note = "measured temperature channel"
        return Regressors(names, np.column_stack([change, change * s.predicted]), (), note + CENTRED)
    energy = np.cumsum(s.measured * s["velocity"]) * s.sample_period
    energy -= np.mean(energy)
    names = ("dissipated energy - its mean [J]", f"(dissipated energy - its mean) * predicted {s.output}")
    note = (
        f"no temperature channel: dissipated energy ∫{s.output}·velocity dt as the proxy of heating; a temperature "
        "channel (oil or tube thermocouple, temperature [K]) would measure it directly"
    )
    return Regressors(names, np.column_stack([energy, energy * s.predicted]), ("temperature",), note + CENTRED)


def _frequency_dependence(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    x, dt = s["displacement"], s.sample_period
    taus = settings.lp_time_constants
    columns = [x - _low_pass(x, tau, dt) for tau in taus]
    names = tuple(f"displacement - lowpass(displacement, {tau:g} s)" for tau in taus)
    note = "viscoelastic internal states (Maxwell elements) at time constants " + ", ".join(f"{t:g}" for t in taus)
    return Regressors(names, np.column_stack(columns), (), note + " s" + _derived_note(s, "displacement"))


def _amplitude_dependence(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    x, dt, window = s["displacement"], s.sample_period, settings.amplitude_window
    first = x[: max(2, int(round(window / dt)))]  # start the running values where the first window puts them
    mean = _low_pass(x, window, dt, float(np.mean(first)))
    spread = _low_pass((x - mean) ** 2, window, dt, float(np.var(first)))
    amplitude = np.sqrt(2 * np.maximum(spread, 0.0))
    amplitude -= np.mean(amplitude)
    names = (f"(running amplitude - its mean) * predicted {s.output}", "(running amplitude - its mean) * displacement")
    note = f"running displacement amplitude (√2·rms over {window:g} s) scaling the force and the stiffness"
    return Regressors(names, np.column_stack([amplitude * s.predicted, amplitude * x]), (), note + CENTRED)


def _sensor_offset(s: EffectSignals, settings: DiagnosisSettings) -> Regressors:
    t = s.time - s.time[0]
    span = t[-1] if t[-1] > 0 else 1.0
    matrix = np.column_stack([np.ones_like(t), t / span])
    return Regressors(("1 (offset)", "time / record length (drift)"), matrix, (), "constant offset and linear drift")


EFFECTS: dict[str, EffectFamily] = {
    family.name: family
    for family in (
        EffectFamily("seal_friction", "Coulomb friction of seals and guides", ("velocity",), _seal_friction),
        EffectFamily("gas_force", "gas spring: preload and displacement dependence", ("displacement",), _gas_force),
        EffectFamily(
            "hysteresis", "memory: compliance lag, force build-up after reversals", ("velocity",), _hysteresis
        ),
        EffectFamily(
            "backlash", "play at motion reversals: dead zone, then re-engagement over the gap's travel",
            ("displacement", "velocity"), _backlash,
        ),
        EffectFamily("inertia", "moving mass between load cell and actuator", ("acceleration",), _inertia),
        EffectFamily("temperature", "damping fade with oil temperature", ("velocity",), _temperature),
        EffectFamily(
            "frequency_dependence", "viscoelastic internal states", ("displacement",), _frequency_dependence
        ),
        EffectFamily(
            "amplitude_dependence", "force scaled by the running amplitude", ("displacement",), _amplitude_dependence
        ),
        EffectFamily("sensor_offset", "load-cell offset or slow drift", (), _sensor_offset),
    )
}


def select_families(names: tuple[str, ...] | None) -> list[EffectFamily]:
    """The families named (None: all, in library order); an unknown name raises DiagnosisError listing the library."""
    if names is None:
        return list(EFFECTS.values())
    unknown = [name for name in names if name not in EFFECTS]
    if unknown:
        raise DiagnosisError(f"unknown effect(s) {', '.join(map(repr, unknown))}; the library has {', '.join(EFFECTS)}")
    return [EFFECTS[name] for name in names]
