"""Which physics the stop-operator family stands for: mechanical play or a seal's pre-sliding stiffness.

Both are rate-independent memories that stop operators of the displacement fit alike (a Jenkins element is
F = k·stop(x, F_s/k)); they differ in the shape of the force after a motion reversal. Play: the force stops changing
(it vanishes, or the old contact unloads) until the gap is crossed, then the contact re-engages, so the slope of
force against travel falls and rises again. A Jenkins element (seal friction with pre-sliding stiffness): the force
changes at the pre-sliding stiffness, then saturates at the break-away force, so the slope only ever falls.

The reading is taken on what the model misses: the residual beyond the recalibration (held-out errors of the
cross-fit, as the ranking's base), signed by the direction of motion and averaged in bins of travel since the last
reversal (bin width half the smallest of `reversal_fractions` times the mean travel between reversals, up to the
largest fraction: the range the stop bank covers). With slopes sigma_j between neighbouring bins, the dead-zone
index is max over k of (sigma_k - min_{j<k} sigma_j) / sigma_k, over the bins whose slope reaches a quarter of the
steepest (a re-engagement, not the noise of a saturated tail): how far the slope had fallen before it rose again,
as a share of the re-engaging slope. 0 or below: the slope only falls (elastic-plastic); 1: it fell to zero (a flat
dead zone); above 1: the force even went back inside the gap. At or above DEAD_ZONE the shape is a dead zone's.
Measured: 20 s random rig records with a seal's pre-sliding stiffness -0.19 to 0.15, behind a 0.5 mm mount clearance
5.7-6.1 (seeds 1-3, tests/diagnosis/test_stop_reading.py); the shipped slice of the measured BRFD friction damper
with backlash 2.7 (a velocity-only least-squares model) and 5.4 (the loop test's velocity-only network).

A fall and rise after reversals is not yet a dead zone: a model that lags the force after a reversal (a short
training, a missing valve lag) or misses the hysteresis loop leaves it as well (the quick demo's damper without play:
index 5.4). So play is named only with the evidence a gap leaves and nothing else explains: the stop operators must
explain, beyond the recalibration and every other effect ranked (hysteresis, seal friction, gas force, ...), at least
PLAY_SHARE of the residual variance at the ranking's family-wise significance (`play_support`). Measured (20 s random
rig records, seeds 1-3; the BRFD slice): behind a 0.5 mm mount clearance 19-42 %, the BRFD damper 62 %; dampers
without play whose model misses the gas force and the oil's warming -0.1 %, the hysteresis -> 2.4-3.3 %, a
velocity-only least-squares model below 2 %, the quick demo's network 2.4 %. Without that support neither play nor
pre-sliding friction is named (a dead-zone shape is not pre-sliding), and the stop family is not ranked unless it
alone was asked for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.diagnosis.effects import EFFECTS, Effect, StopFamily
from nnfmu.diagnosis.effects.shared import mean_stroke, reversal_travel
from nnfmu.diagnosis.ranking import GainTest, extend_base, fold_mask, gain_test
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals

DEAD_ZONE = 0.5  # dead-zone index at or above which the stop family reads as play
ENGAGING = 0.25  # a slope counts as a re-engagement when it reaches this share of the steepest
MIN_BIN = 10  # samples a travel bin needs for its mean to count
# Share of the residual variance the stop operators must explain beyond every other effect for play to be named
# (module docstring: 19-62 % with play, at most 3.3 % without).
PLAY_SHARE = 0.10


@dataclass(frozen=True)
class StopReading:
    """The dead-zone index (None: too few reversals to tell), the shape it reads ("dead_zone", "elastic_plastic",
    or "unsupported": a dead zone's shape or too few reversals, without the support play needs), the effect named
    for it (None when unsupported), the travel bins' centres [m] and the signed residual's mean level in each
    [output unit] (NaN where too few samples), the stop operators' gain beyond every other effect (None when not
    needed), and the reading in words."""

    index: float | None
    shape: str
    effect: str | None
    travel: tuple[float, ...]
    level: tuple[float, ...]
    text: str
    support: GainTest | None = None

    def to_dict(self) -> dict:
        return {
            "dead_zone_index": self.index,
            "threshold": DEAD_ZONE,
            "shape": self.shape,
            "effect": self.effect,
            "play_support": None
            if self.support is None
            else {"explained": self.support.explained, "p_value": self.support.p_value, "required": PLAY_SHARE},
            "travel_m": list(self.travel),
            "level": [None if not np.isfinite(x) else float(x) for x in self.level],
            "text": self.text,
        }


def travel_levels(
    signals: EffectSignals, errors: np.ndarray, settings: DiagnosisSettings
) -> tuple[np.ndarray, np.ndarray]:
    """(bin centres [m], mean direction-signed `errors` per bin, NaN below MIN_BIN samples) over the travel since the
    last reversal."""
    direction, travel = reversal_travel(signals["velocity"], signals.sample_period)
    stroke = mean_stroke(signals["velocity"], signals.sample_period) or 1.0
    width = 0.5 * min(settings.reversal_fractions) * stroke
    count = max(3, int(round(max(settings.reversal_fractions) * stroke / width)))
    finite = np.isfinite(travel)
    index = np.full(len(travel), -1)
    index[finite] = np.minimum(travel[finite] // width, count).astype(int)
    signed = direction * errors
    level = np.array([np.mean(signed[index == j]) if np.sum(index == j) >= MIN_BIN else np.nan for j in range(count)])
    return (np.arange(count) + 0.5) * width, level


def dead_zone_index(travel: np.ndarray, level: np.ndarray) -> float | None:
    """The dead-zone index of the levels at the bin centres `travel` (module docstring; bins without a level are
    skipped), None when fewer than 3 bins count or no slope rises."""
    keep = np.isfinite(level)
    travel, level = travel[keep], level[keep]
    if len(level) < 3:
        return None
    if level[-1] < level[0]:
        level = -level  # orient: the force the new direction builds up rises
    slope = np.diff(level) / np.diff(travel)
    steepest = float(np.max(slope))
    if steepest <= 0:
        return None
    values = [
        (slope[k] - np.min(slope[:k])) / slope[k] for k in range(1, len(slope)) if slope[k] >= ENGAGING * steepest
    ]
    return float(max(values, default=0.0))


def play_support(
    signals: EffectSignals,
    residual: np.ndarray,
    base: np.ndarray,
    families: list[Effect],
    settings: DiagnosisSettings,
) -> GainTest:
    """What the stop operators explain of `residual` out of sample beyond `base` (the recalibration) and every other
    testable family of `families`: the part of the residual only a gap (or a pre-sliding memory) accounts for."""
    for family in families:
        if not isinstance(family, StopFamily) and not family.missing(signals):
            base = extend_base(base, family.regressors(signals, settings).matrix)
    stops = EFFECTS["backlash"].regressors(signals, settings).matrix
    return gain_test(residual, base, stops, fold_mask(len(residual), settings.blocks))


def p_words(p: float) -> str:
    """A p-value in a sentence: `p = 3.2e-05`, or `p < 1e-12` where the normal tail is only rounding."""
    return f"p = {p:.2g}" if p >= 1e-12 else "p < 1e-12"


def read_stops(
    signals: EffectSignals,
    errors: np.ndarray,
    settings: DiagnosisSettings,
    support: GainTest | None = None,
    threshold: float = 1.0,
) -> StopReading:
    """Read the shape after reversals of `errors` (the residual's held-out errors beyond the recalibration) as play
    (`backlash`) or pre-sliding seal friction (`presliding_friction`). Play (a dead zone's shape, or too few
    reversals to tell) needs `support` (`play_support`): at least PLAY_SHARE explained with a p-value below
    `threshold`; without it the reading is "unsupported" and names no effect (no support given: not checked)."""
    travel, level = travel_levels(signals, errors, settings)
    index = dead_zone_index(travel, level)
    names = {"dead_zone": "backlash", "elastic_plastic": "presliding_friction"}
    shape = "dead_zone" if index is None or index >= DEAD_ZONE else "elastic_plastic"
    seen = (
        "too few reversals to tell a dead zone from an elastic-plastic loop"
        if index is None
        else f"after a reversal the residual's slope against travel falls and rises again (dead-zone index "
        f"{index:.2f} >= {DEAD_ZONE})"
    )
    supported = support is None or (support.explained >= PLAY_SHARE and support.p_value < threshold)
    if shape == "dead_zone" and not supported:
        assert support is not None
        words = (
            f"{seen}, but they explain only {support.explained:.1%} of the residual variance beyond every other "
            f"effect ({p_words(support.p_value)}; play needs {PLAY_SHARE:.0%} at the family-wise threshold "
            f"{threshold:.2g}): no dead zone is named (a force lagging after reversals or a missing hysteresis "
            "loop leaves such a shape too), nor pre-sliding friction"
        )
        return StopReading(index, "unsupported", None, tuple(travel), tuple(level), f"stop operators: {words}", support)
    if index is None:
        words = f": {seen}, named backlash"
    elif shape == "dead_zone":
        words = (
            f" read as mechanical play: {seen} once the gap is crossed, a dead zone, not a seal's pre-sliding stiffness"
        )
    else:
        words = (
            f" read as seal friction with pre-sliding stiffness: after a reversal the force changes stiffly, then "
            f"saturates, its slope never rising again (dead-zone index {index:.2f} < {DEAD_ZONE}), an elastic-plastic "
            f"(Jenkins) loop, not mechanical play"
        )
    if shape == "dead_zone" and support is not None:
        words += (
            f" ({support.explained:.1%} of the residual variance beyond every other effect, {p_words(support.p_value)})"
        )
    return StopReading(
        index, shape, names[shape], tuple(travel), tuple(level), f"stop operators of displacement{words}", support
    )


def keep_reading(families: list[Effect], reading: StopReading) -> list[Effect]:
    """`families` with only the stop family the reading names (none when it names none), when more than one is asked
    for (one set of columns is ranked once, under the name of what it shows); a single one asked for is kept as
    asked."""
    stops = [f for f in families if isinstance(f, StopFamily)]
    if len(stops) < 2:
        return families
    return [f for f in families if not isinstance(f, StopFamily) or f.name == reading.effect]
