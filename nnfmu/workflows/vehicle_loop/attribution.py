"""Attribute the vehicle residual to (component, effect) pairs and sensor offsets by the evidence in every measured
channel at once.

Candidates: each component element's effect as parameterised physical terms on its network's output (a damper's
`gas_force`: a preload and a rate times its displacement; a bushing's `stiffness`: a rate times each deflection or
rotation on its own force or torque),
and a `sensor_offset` per measured channel (a constant in that channel alone). A component effect moves several
channels consistently; its sensitivity is measured in the co-simulation: the network FMU with one term added at a
known coefficient, swapped into the system and replayed, gives the change of every channel per unit coefficient
(first order in the coefficient). The residual (measured - virtual, each channel divided by the measured channel's
standard deviation, so every channel counts in fractions of its own signal) is then explained by the candidates'
columns, all channels stacked, out of sample: the record's blocks are halved at random (`fold_mask`), each half
predicted by the fit on the other. The test is the component diagnosis's (Diebold-Mariano on the held-out squared
errors, summed over channels at each instant, with the Newey-West long-run variance), Bonferroni over the
candidates. Forward selection: the candidate explaining most, if significant and above `min_explained`, is named;
the rest are tested again beyond it. A sensor offset and a gas preload both shift their load cell; only the preload
also lifts the corner (displacement, LCA angle), so the two part here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.diagnosis.correlation import newey_west_variance
from nnfmu.diagnosis.ranking import cross_fit_errors, extend_base, fold_mask
from nnfmu.export.terms import OutputTerm

SENSOR_OFFSET = "sensor_offset"
ALIKE = 0.9  # a rival explaining at least this share of what the named candidate explains, with predictions this
# correlated, cannot be told apart from it by these channels


@dataclass(frozen=True)
class Candidate:
    """A (component, effect) with the basis terms it adds to the component's network (each at the coefficient its
    sensitivity is measured with), or a sensor offset on `channel` (no terms). With `joint_step` the terms are one
    basis together (their coefficients the effect at unit amplitude), its sensitivity measured at `joint_step` times
    them: one fitted amplitude scales them all."""

    component: str
    effect: str
    terms: tuple[OutputTerm, ...] = ()
    channel: str | None = None
    joint_step: float | None = None

    def fitted_terms(self, coefficients: tuple[float, ...]) -> tuple[OutputTerm, ...]:
        """The terms at the fitted `coefficients` (one amplitude for joint terms, else one per term)."""
        if self.joint_step is not None:
            (amplitude,) = coefficients
            return tuple(OutputTerm(t.output, t.channel, amplitude * t.coefficient, t.unit) for t in self.terms)
        return tuple(OutputTerm(t.output, t.channel, c, t.unit) for t, c in zip(self.terms, coefficients))

    @property
    def key(self) -> str:
        return f"{self.component}:{self.effect}"


def damper_candidates(element: str) -> list[Candidate]:
    """A damper's candidate effects as terms on its force (tension positive): the gas spring pushes out with its
    preload and more on compression, -preload + rate x."""
    return [
        Candidate(
            element,
            "gas_force",
            (OutputTerm("force", None, -100.0, "N"), OutputTerm("force", "displacement", 2000.0, "m")),
        )
    ]


def bushing_candidates(element: str, stiffness: Mapping[str, float], step: float) -> list[Candidate]:
    """A bushing's candidate effects: `stiffness` (aged rubber stiffens every channel alike), the element's own
    stiffness per channel (`stiffness`: force or torque output -> N/m or N.m/rad) times that channel's deflection or
    rotation on its own output, all channels one basis whose fitted amplitude is the fraction of stiffness added;
    its sensitivity measured at `step` (a fraction) of it."""
    terms = tuple(
        OutputTerm(ch.force, ch.position, stiffness[ch.force], ch.position_unit)
        for ch in BUSHING_CHANNELS.values()
        if ch.force in stiffness
    )
    return [Candidate(element, "stiffness", terms, joint_step=step)] if terms else []


def offset_candidate(channel: str) -> Candidate:
    """A zero offset of one measured channel."""
    return Candidate(channel, SENSOR_OFFSET, (), channel)


@dataclass(frozen=True)
class Evidence:
    """What one candidate explains: out of sample, alone and beyond those named before it (fractions of the
    residual's variance), the p-value of the latter, the effective sample size, the fitted coefficients (terms'
    units; a sensor offset in its channel's) and the share of each channel's residual variance it explains."""

    candidate: Candidate
    explained_alone: float
    explained: float
    p_value: float
    effective_samples: float
    coefficients: tuple[float, ...]
    channels: dict[str, float]
    named: bool
    alike: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, object]:
        return {
            "component": self.candidate.component,
            "effect": self.candidate.effect,
            "explained_alone": self.explained_alone,
            "explained": self.explained,
            "p_value": self.p_value,
            "effective_samples": self.effective_samples,
            "coefficients": list(self.coefficients),
            "terms": [
                {"output": t.output, "channel": t.channel, "unit": t.unit}
                | ({"rate_per_unit_amplitude": t.coefficient} if self.candidate.joint_step is not None else {})
                for t in self.candidate.terms
            ],
            "channels_explained": self.channels,
            "named": self.named,
            "cannot_tell_apart_from": list(self.alike),
        }


@dataclass(frozen=True)
class Attribution:
    """Every candidate's evidence, the named ones first in the order named; the significance threshold used."""

    evidence: list[Evidence]
    threshold: float
    untestable: dict[str, str] = field(default_factory=dict)

    @property
    def named(self) -> list[Evidence]:
        return [e for e in self.evidence if e.named]


def _stack(columns: list[np.ndarray]) -> np.ndarray:
    """(n, C) arrays as columns of one (n*C, k) design, channel after channel."""
    if not columns:
        return np.zeros((0, 0))
    return np.column_stack([c.ravel(order="F") for c in columns])


def _gain(target: np.ndarray, base: np.ndarray, extra: np.ndarray, fold: np.ndarray, n: int) -> tuple[float, ...]:
    """(explained, p-value, effective samples) of `extra` beyond `base` on the stacked target, held out."""
    e_base = cross_fit_errors(target, base, fold)
    e_full = cross_fit_errors(target, extend_base(base, extra), fold)
    sse = float(np.sum(e_base**2))
    explained = 1 - float(np.sum(e_full**2)) / sse if sse > 0 else 0.0
    d = (e_base**2 - e_full**2).reshape(-1, n).sum(axis=0)  # per instant, over channels
    long_run, _ = newey_west_variance(d)
    variance = max(long_run, float(np.var(d)))
    if variance <= 0:
        return explained, 0.5, float(n)
    statistic = float(np.mean(d) / np.sqrt(variance / n))
    return explained, float(stats.norm.sf(statistic)), float(n * np.var(d) / variance)


def attribute(
    residual: np.ndarray,
    channels: list[str],
    sensitivities: Mapping[str, list[np.ndarray]],
    candidates: Mapping[str, Candidate],
    blocks: int,
    alpha: float,
    min_explained: float,
    max_named: int,
    untestable: Mapping[str, str] | None = None,
) -> Attribution:
    """Forward selection of `candidates` (key -> Candidate, with `sensitivities[key]`: one (n, C) array per basis
    term, per unit coefficient, in the residual's scaling) on `residual` (n, C), see the module docstring."""
    n = residual.shape[0]
    target = residual.ravel(order="F")
    fold = np.tile(fold_mask(n, blocks), residual.shape[1])
    designs = {key: _stack(columns) for key, columns in sensitivities.items()}
    threshold = alpha / max(len(designs), 1)
    base = np.zeros((len(target), 0))
    alone = {key: _gain(target, base, d, fold, n) for key, d in designs.items()}
    named: list[str] = []
    tests: dict[str, tuple[float, ...]] = {}
    remaining = list(designs)
    while remaining and len(named) < max_named:
        tests |= {key: _gain(target, base, designs[key], fold, n) for key in remaining}
        good = [k for k in remaining if tests[k][1] < threshold and tests[k][0] >= min_explained]
        if not good:
            break
        best = max(good, key=lambda k: tests[k][0])
        named.append(best)
        remaining.remove(best)
        base = extend_base(base, designs[best])
    tests |= {key: _gain(target, base, designs[key], fold, n) for key in remaining if key not in tests}
    evidence = []
    for key in named + sorted(remaining, key=lambda k: -alone[k][0]):
        coefficients = _coefficients(target, designs, named, key)
        fitted = designs[key] @ coefficients[key]
        per_channel = _per_channel(residual, fitted.reshape(residual.shape, order="F"), channels)
        evidence.append(
            Evidence(
                candidate=candidates[key],
                explained_alone=alone[key][0],
                explained=tests[key][0],
                p_value=tests[key][1],
                effective_samples=tests[key][2],
                coefficients=tuple(float(c) for c in coefficients[key]),
                channels=per_channel,
                named=key in named,
                alike=_alike(key, named, designs, alone, coefficients) if key in named else (),
            )
        )
    return Attribution(evidence, threshold, dict(untestable or {}))


def _coefficients(target: np.ndarray, designs: Mapping[str, np.ndarray], named: list[str], key: str) -> dict:
    """Least-squares coefficients (per unit of each basis column) of the named candidates together with `key`."""
    keys = list(dict.fromkeys([*named, key]))
    design = np.column_stack([designs[k] for k in keys])
    solved = np.linalg.lstsq(design, target, rcond=None)[0]
    out, start = {}, 0
    for k in keys:
        width = designs[k].shape[1]
        out[k] = solved[start : start + width]
        start += width
    return out


def _per_channel(residual: np.ndarray, fitted: np.ndarray, channels: list[str]) -> dict[str, float]:
    """Share of each channel's residual variance (mean included) the fitted candidate removes, in-sample."""
    before = np.sum(residual**2, axis=0)
    after = np.sum((residual - fitted) ** 2, axis=0)
    return {c: float(1 - a / b) if b > 0 else 0.0 for c, a, b in zip(channels, after, before)}


def _alike(
    key: str,
    named: list[str],
    designs: Mapping[str, np.ndarray],
    alone: Mapping[str, tuple[float, ...]],
    coefficients: Mapping[str, np.ndarray],
) -> tuple[str, ...]:
    """Candidates the channels cannot tell from `key`: explaining alone nearly as much, with nearly the same fit."""
    mine = designs[key] @ coefficients[key]
    found = []
    for other, design in designs.items():
        if other == key or other in named or alone[other][0] < ALIKE * alone[key][0]:
            continue
        theirs = design @ np.linalg.lstsq(design, mine, rcond=None)[0]
        if np.dot(theirs, theirs) >= ALIKE**2 * np.dot(mine, mine):
            found.append(other)
    return tuple(found)
