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
training, a missing valve lag) leaves it as well (the quick demo's damper without play: index 5.4). So play is named
only when the stop operators are also significant in the ranking (they explain a significant share of the residual
beyond the recalibration and the effects selected before them, family-wise; `supported`): the quick demo's were not
(2.3 %), a damper behind a mount clearance's and the BRFD damper's were, ranked first. Otherwise the reading is
"unsupported": it names neither play nor pre-sliding friction, and the stop family leaves the ranking unless it alone
was asked for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.diagnosis.effects import Effect, StopFamily
from nnfmu.diagnosis.effects.shared import mean_stroke, reversal_travel
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals

DEAD_ZONE = 0.5  # dead-zone index at or above which the stop family reads as play
ENGAGING = 0.25  # a slope counts as a re-engagement when it reaches this share of the steepest
MIN_BIN = 10  # samples a travel bin needs for its mean to count


@dataclass(frozen=True)
class StopReading:
    """The dead-zone index (None: too few reversals to tell), the shape it reads ("dead_zone", "elastic_plastic",
    or "unsupported": a dead zone's shape or too few reversals whose stop family was not significant in the
    ranking), the effect named for it (None when unsupported), the travel bins' centres [m] and the signed
    residual's mean level in each [output unit] (NaN where too few samples), and the reading in words."""

    index: float | None
    shape: str
    effect: str | None
    travel: tuple[float, ...]
    level: tuple[float, ...]
    text: str

    def to_dict(self) -> dict:
        return {
            "dead_zone_index": self.index,
            "threshold": DEAD_ZONE,
            "shape": self.shape,
            "effect": self.effect,
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


def p_words(p: float) -> str:
    """A p-value in a sentence: `p = 3.2e-05`, or `p < 1e-12` where the normal tail is only rounding."""
    return f"p = {p:.2g}" if p >= 1e-12 else "p < 1e-12"


def read_stops(signals: EffectSignals, errors: np.ndarray, settings: DiagnosisSettings) -> StopReading:
    """Read the shape after reversals of `errors` (the residual's held-out errors beyond the recalibration) as play
    (`backlash`) or pre-sliding seal friction (`presliding_friction`); too few reversals to tell keep the name
    `backlash`. Play still needs the ranking's support (`supported`)."""
    travel, level = travel_levels(signals, errors, settings)
    index = dead_zone_index(travel, level)
    names = {"dead_zone": "backlash", "elastic_plastic": "presliding_friction"}
    if index is None:
        return StopReading(
            None,
            "dead_zone",
            names["dead_zone"],
            tuple(travel),
            tuple(level),
            "stop operators of displacement: too few reversals to tell a dead zone from an elastic-plastic loop, "
            "named backlash",
        )
    shape = "dead_zone" if index >= DEAD_ZONE else "elastic_plastic"
    if shape == "dead_zone":
        words = (
            f"read as mechanical play: after a reversal the slope of the force against travel falls and rises again "
            f"once the gap is crossed (dead-zone index {index:.2f} >= {DEAD_ZONE}), a dead zone, not a seal's "
            f"pre-sliding stiffness"
        )
    else:
        words = (
            f"read as seal friction with pre-sliding stiffness: after a reversal the force changes stiffly, then "
            f"saturates, its slope never rising again (dead-zone index {index:.2f} < {DEAD_ZONE}), an elastic-plastic "
            f"(Jenkins) loop, not mechanical play"
        )
    return StopReading(
        index, shape, names[shape], tuple(travel), tuple(level), f"stop operators of displacement {words}"
    )


def supported(reading: StopReading, significant: bool, explained: float | None) -> StopReading:
    """`reading` as it is when it names no play or its stop family was `significant` in the ranking (explaining
    `explained` of the residual variance beyond the effects selected before it); else "unsupported", naming nothing."""
    if reading.shape != "dead_zone" or significant:
        return reading
    seen = "too few reversals to tell" if reading.index is None else f"dead-zone index {reading.index:.2f}"
    share = "nothing" if explained is None else f"only {explained:.1%} of the residual variance"
    text = (
        f"stop operators of displacement: a dead zone's shape after reversals ({seen}), but they explain {share} "
        "beyond the effects above, not significantly: no play is named (a force lagging after reversals leaves "
        "such a shape too), nor pre-sliding friction"
    )
    return StopReading(reading.index, "unsupported", None, reading.travel, reading.level, text)


def keep_reading(families: list[Effect], reading: StopReading) -> list[Effect]:
    """`families` with only the stop family the reading names (none when it names none), when more than one is asked
    for (one set of columns is ranked once, under the name of what it shows); a single one asked for is kept as
    asked."""
    stops = [f for f in families if isinstance(f, StopFamily)]
    if len(stops) < 2:
        return families
    return [f for f in families if not isinstance(f, StopFamily) or f.name == reading.effect]
