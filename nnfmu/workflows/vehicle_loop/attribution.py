"""Attribute the vehicle residual to (component, effect) pairs and sensor offsets by the evidence in every measured
channel at once.

Candidates: the effects of the diagnosis's `SYSTEM_EFFECTS` that each component element's kind names
(`ComponentKind.loop_effects`), as parameterised physical terms on its network's output (a damper's `gas_force`: a
preload and a rate times its displacement; a bushing's `stiffness`: a rate times each deflection or rotation on its
own force or torque), and each measured channel's own error (`sensor_offset`: a constant in that channel alone). A
component effect moves several channels consistently; its sensitivity is measured in the co-simulation: the network
FMU with one term added at a known coefficient, swapped into the system and replayed, gives the change of every
channel per unit coefficient (first order in the coefficient). The residual (measured - virtual, each channel
divided by the measured channel's standard deviation, so every channel counts in fractions of its own signal) is
then explained by the candidates' columns, all channels stacked, out of sample: the record's blocks are halved at
random (`fold_mask`), each half predicted by the fit on the other. The test is the component diagnosis's
(Diebold-Mariano on the held-out squared errors, summed over channels at each instant, with the Newey-West long-run
variance), Bonferroni over the candidates. Forward selection: of the candidates significant and above
`min_explained`, the one lowering an information criterion most is named (its held-out gain against ln(n_eff) per
fitted parameter, `_delta_bic`: a gas force's two coefficients are charged twice an offset's one); the rest are
tested again beyond it. A sensor offset and a gas preload both shift their load cell; only the preload also lifts
the corner (displacement, LCA angle), so the two part here.

One physical cause before several offsets: when sensor offsets were named, stories with physical causes first are
tried against the named one: each physical candidate left out in place of two or more named offsets (the named
physical candidates and it, then those offsets still significant beyond them, by the same forward rule; it must
keep fewer offsets), and the physical candidates selected first with every offset considered beyond them (no more
offsets than named). Every offset such a story keeps must explain the residual by itself as well (an offset that
explains something only beyond the causes is cancelling their own prediction in a channel that showed nothing), and
every cause must explain it beyond the rest of its story.
The stories are compared by an information criterion charging each fitted parameter, BIC = n_eff ln(SSE / n_eff) + k
ln(n_eff) (SSE of the held-out errors of all channels, n_eff the residual's effective sample count, k the fitted
coefficients: one per offset, two for a gas force); the lower wins, a tie (within `BIC_TIE`) goes to the physical cause:
two offsets that happen to satisfy the car's static balance give way to the one gas force that explains both, and where
the channels cannot tell the stories apart (one deflection sensor: preload, load-cell and stroke offsets are three knobs
for two static numbers) the report says so.
Every named candidate carries `why`: the rivals it beat in its round and by how much, or the comparison of stories.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from nnfmu.diagnosis import SYSTEM_EFFECTS, SystemEffect, cross_fit_errors, extend_base, fold_mask, newey_west_variance
from nnfmu.export.terms import OutputTerm
from nnfmu.kinds import BUSHING, KindChannel

# The registry's error of one measured channel, fitted as a constant in that channel alone (looked up: the import
# fails if the registry loses it).
SENSOR_OFFSET = SYSTEM_EFFECTS["sensor_offset"].name
BIC_TIE = 2.0  # stories whose BIC differ by less are a tie ("not worth more than a bare mention", Kass & Raftery
# 1995): the one with fewer sensor offsets is named
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


def component_candidate(
    element: str,
    effect: SystemEffect,
    channels: Sequence[KindChannel],
    stiffness: Mapping[str, float],
    step: float,
) -> Candidate | None:
    """`effect` on the component `element` of these kind `channels` as terms on its network's output (the element's
    own `stiffness` per channel, force or torque output -> N/m or N.m/rad, where the effect scales by it), a joint
    basis measured at `step` (a fraction) of it; None where the effect offers no terms."""
    terms = tuple(OutputTerm(t.output, t.channel, t.coefficient, t.unit) for t in effect.terms(channels, stiffness))
    if not terms:
        return None
    return Candidate(element, effect.name, terms, joint_step=step if effect.joint else None)


def bushing_candidates(element: str, stiffness: Mapping[str, float], step: float) -> list[Candidate]:
    """A bushing's `stiffness` candidate (aged rubber stiffens every channel alike: one amplitude on the element's
    own stiffness per channel), none where no channel's stiffness is known."""
    made = component_candidate(element, SYSTEM_EFFECTS["stiffness"], BUSHING.channels, stiffness, step)
    return [made] if made is not None else []


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
    why: str = ""

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
            "why": self.why,
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
    selection = Selection(target, designs, fold, n, threshold, min_explained, max_named)
    alone = {key: selection.gain([], key) for key in designs}
    why: dict[str, str] = {}
    named, tests = selection.select([], list(designs), why)
    named, replaced = one_cause(named, candidates, selection, why)
    if replaced:
        tests = {key: selection.gain(named[: named.index(key)] if key in named else named, key) for key in designs}
    remaining = [k for k in designs if k not in named]
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
                alike=_alike(key, named, selection, coefficients) if key in named else (),
                why=why.get(key, "") if key in named else "",
            )
        )
    return Attribution(evidence, threshold, dict(untestable or {}))


def _design(designs: Mapping[str, np.ndarray], keys: list[str], rows: int) -> np.ndarray:
    """The named candidates' columns side by side, rescaled as forward selection builds them."""
    base = np.zeros((rows, 0))
    for key in keys:
        base = extend_base(base, designs[key])
    return base


@dataclass(frozen=True)
class Selection:
    """The stacked residual `target` (n instants x channels), each candidate's design, the folds and the rules of
    forward selection."""

    target: np.ndarray
    designs: Mapping[str, np.ndarray]
    fold: np.ndarray
    n: int
    threshold: float
    min_explained: float
    max_named: int

    def gain(self, named: list[str], key: str) -> tuple[float, ...]:
        """(explained, p-value, effective samples) of `key` beyond `named`, held out."""
        base = _design(self.designs, named, len(self.target))
        return _gain(self.target, base, self.designs[key], self.fold, self.n)

    def select(
        self, start: list[str], pool: list[str], why: dict[str, str] | None = None
    ) -> tuple[list[str], dict[str, tuple[float, ...]]]:
        """Forward selection from `start` over `pool`: the named keys and the last tests of every key tested (each
        named one's in the round it was named); with `why`, each named key's reason."""
        chosen, tests = list(start), {}
        base = _design(self.designs, chosen, len(self.target))
        remaining = [k for k in pool if k not in chosen]
        while remaining and len(chosen) < self.max_named:
            tests |= {k: _gain(self.target, base, self.designs[k], self.fold, self.n) for k in remaining}
            good = [k for k in remaining if self.passes(tests[k])]
            if not good:
                break
            best = min(good, key=lambda k: _delta_bic(tests[k], self.designs[k].shape[1]))
            if why is not None:
                why[best] = _beaten(best, remaining, tests, good)
            chosen.append(best)
            remaining.remove(best)
            base = extend_base(base, self.designs[best])
        tests |= {k: _gain(self.target, base, self.designs[k], self.fold, self.n) for k in remaining if k not in tests}
        return chosen, tests

    def passes(self, test: tuple[float, ...]) -> bool:
        """Whether a held-out test (explained, p-value, ...) is significant and explains at least `min_explained`:
        forward selection's rule for naming a candidate."""
        return test[1] < self.threshold and test[0] >= self.min_explained

    def explains_beyond(self, named: list[str], key: str) -> bool:
        """Whether `key` explains the residual beyond `named` by forward selection's rule (`passes`)."""
        return self.passes(self.gain(named, key))

    def bic(self, keys: list[str]) -> float:
        """BIC of the story `keys` (module docstring): held-out SSE of all channels, the residual's effective sample
        count, one charge per fitted coefficient."""
        errors = cross_fit_errors(self.target, _design(self.designs, keys, len(self.target)), self.fold)
        d = (errors**2).reshape(-1, self.n).sum(axis=0)  # per instant, over channels
        long_run, _ = newey_west_variance(d)
        variance = max(long_run, float(np.var(d)))
        n_eff = max(self.n * float(np.var(d)) / variance if variance > 0 else float(self.n), 2.0)
        sse = max(float(np.sum(errors**2)), 1e-300)
        parameters = sum(self.designs[k].shape[1] for k in keys)
        return n_eff * float(np.log(sse / n_eff)) + parameters * float(np.log(n_eff))


def _delta_bic(test: tuple[float, ...], parameters: int) -> float:
    """The change of BIC when a candidate is named: its held-out gain (explained share, over its effective sample
    count) against a charge of ln(n_eff) per fitted parameter; lower is better."""
    explained, _, n_eff = test[0], test[1], max(test[2], 2.0)
    return n_eff * float(np.log(max(1.0 - explained, 1e-12))) + parameters * float(np.log(n_eff))


def _beaten(best: str, remaining: list[str], tests: Mapping[str, tuple[float, ...]], good: list[str]) -> str:
    """Why `best` was named in its round: what it explained beyond those named before and its BIC change, against
    its closest rivals."""
    rivals = sorted((k for k in remaining if k != best), key=lambda k: -tests[k][0])[:2]
    words = f"explained {tests[best][0]:.1%} beyond those named before"
    if not rivals:
        return words + "; no rival left"
    listed = ", ".join(f"{k} {tests[k][0]:.1%}" + ("" if k in good else " (not significant)") for k in rivals)
    return f"{words}, the largest drop of BIC (each fitted parameter charged) against its closest rivals ({listed})"


def one_cause(
    named: list[str], candidates: Mapping[str, Candidate], selection: Selection, why: dict[str, str]
) -> tuple[list[str], bool]:
    """Stories where physical causes come before offsets, against the named one when it holds offsets (module
    docstring): each physical candidate left out in place of two or more named offsets (fewer offsets), and the
    physical candidates selected first with the offsets beyond them (no more offsets). An offset a story keeps must
    explain the residual by itself too: one that explains only beyond the causes cancels what they predict in a
    channel that showed nothing (a gas preload's corner lift cancelled by a stroke-sensor offset, standing in for a
    load-cell offset), which is evidence for neither. Each cause must explain the residual beyond the rest of its
    story, as forward selection would name it: else the story is the offsets' with a cause that adds nothing. The
    lowest BIC wins, the physical story winning ties (within `BIC_TIE`); returns the story and whether it changed,
    the winner's reason in `why`."""
    offset = {k for k in selection.designs if candidates[k].effect == SENSOR_OFFSET}
    offsets = [k for k in named if k in offset]
    if not offsets:
        return named, False
    physical = [k for k in named if k not in offset]
    stories: list[tuple[list[str], list[str], int]] = []  # start, pool, most offsets allowed
    if len(offsets) >= 2:
        stories += [
            ([*physical, k], [*physical, k, *offsets], len(offsets) - 1)
            for k in selection.designs
            if k not in named and k not in offset
        ]
    first, _ = selection.select([], [k for k in selection.designs if k not in offset])
    if first and first != physical:
        stories.append((first, [*first, *sorted(offset)], len(offsets)))
    before = selection.bic(named)
    best, best_bic, best_reasons = named, before + BIC_TIE, {}
    for start, pool, most in stories:
        reasons: dict[str, str] = {}
        story, _ = selection.select(start, pool, reasons)
        kept = [k for k in story if k in offset]
        if len(kept) > most or not all(selection.explains_beyond([], k) for k in kept):
            continue  # too many offsets, or one that only cancels what the causes predict
        causes = [k for k in story if k not in offset]
        if not all(selection.explains_beyond([k for k in story if k != c], c) for c in causes):
            continue  # a cause adding nothing beyond the rest of its story
        score = selection.bic(story)
        if score < best_bic:
            best, best_bic, best_reasons = story, score, reasons
    if best is named:
        return named, False
    why.update(best_reasons)  # the offsets kept, named beyond the causes
    causes = [k for k in best if k not in offset]
    kept = [k for k in best if k in offset]
    verdict = (
        "lower wins"
        if best_bic < before - BIC_TIE
        else f"within {BIC_TIE:g} of each other, so these channels cannot tell the two stories apart and the "
        "physical cause is preferred to offsets"
    )
    words = (
        f"physical causes before offsets: {' and '.join(causes)} first, then "
        + (" and ".join(kept) if kept else "no offset")
        + f", in place of {' then '.join(named)}"
    )
    for cause in causes:
        why[cause] = f"{words} (BIC {best_bic:.1f} against {before:.1f}, each fitted parameter charged; {verdict})"
    return best, True


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


def _alike(key: str, named: list[str], selection: Selection, coefficients: Mapping[str, np.ndarray]) -> tuple[str, ...]:
    """Candidates the channels cannot tell from `key`: beyond those named before it, explaining nearly as much with
    nearly the same fit (both taken beyond the earlier named candidates' columns); or, put in its place in the named
    story, leaving the story's BIC within `BIC_TIE` (three knobs for two static numbers)."""
    before = named[: named.index(key)]
    designs = selection.designs
    base = _design(designs, before, len(selection.target))

    def beyond(x: np.ndarray) -> np.ndarray:
        return x - base @ np.linalg.lstsq(base, x, rcond=None)[0] if base.shape[1] else x

    mine = beyond(designs[key] @ coefficients[key])
    mine_gain = selection.gain(before, key)[0]
    story = selection.bic(named)
    found = []
    for other, design in designs.items():
        if other == key or other in named:
            continue
        if selection.bic([other if k == key else k for k in named]) <= story + BIC_TIE:
            found.append(other)
            continue
        if selection.gain(before, other)[0] < ALIKE * mine_gain:
            continue
        own = beyond(design)
        theirs = own @ np.linalg.lstsq(own, mine, rcond=None)[0]
        if np.dot(theirs, theirs) >= ALIKE**2 * np.dot(mine, mine):
            found.append(other)
    return tuple(found)
