"""Rank effect families by the residual variance they explain out of sample, with an autocorrelation-robust test.

Out of sample: the record is cut into `blocks` contiguous blocks, half of them (drawn with a fixed seed) fit and the
other half evaluate, then the other way round, so every sample's error comes from a fit that never saw it.

Every fit carries *recalibration* columns: the model's prediction (a gain error) and its input channels (a linear
term in them). A family only gets credit for what a mere re-tuning of the model could not give, i.e. its *additional*
variance, even where the model's inputs already cover part of the effect (a velocity-history model and the
hysteresis family); without them, any family holding a velocity-like column (a short-time-constant filter state)
would collect the credit for a plain gain error, and rank above the effect that caused it.

Families are selected forward: the family explaining most, if significant, joins the base; the rest are re-tested on
what remains. So two effects at once are both found, and a family that only echoes a selected one (a sensor offset
echoing a gas preload) is not.

The test (why not an F-test): residuals of a model are strongly autocorrelated, so n samples carry far less than n
independent pieces of evidence and a naive F-test overstates significance by orders of magnitude. The test here is
Diebold-Mariano's on the held-out squared errors: d_t = e_base² - e_full², statistic mean(d)/√(LRV(d)/n) with the
Newey-West long-run variance LRV (bandwidth chosen from d's own autocorrelation, and LRV never below var(d), so no
more than n independent samples are ever claimed), one-sided against N(0, 1). The effective sample size
n·var(d)/LRV(d) is reported. For nested fits the test is conservative under "no effect" (the
extra coefficients only add estimation noise to the held-out errors). Significance is family-wise: Bonferroni over
the families tested.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from nnfmu.diagnosis.correlation import newey_west_variance
from nnfmu.diagnosis.effects import Effect, Regressors
from nnfmu.diagnosis.settings import DiagnosisSettings
from nnfmu.diagnosis.signals import EffectSignals

RIDGE = 1e-4  # ridge weight relative to n on unit-rms columns: shrinks only directions with rms below 1 % of a column
FOLD_SEED = 20051  # fixes which blocks fit and which evaluate


@dataclass(frozen=True)
class GainTest:
    """Out-of-sample gain of adding columns to a base fit, and its Diebold-Mariano test."""

    explained: float  # 1 - SSE_full/SSE_base on held-out samples (fraction of the base-fit residual variance)
    p_value: float
    statistic: float
    effective_samples: float
    bandwidth: int


@dataclass(frozen=True)
class RankedFamily:
    """One family's place in the ranking; tests are None when it could not be computed (channels missing)."""

    family: Effect
    regressors: Regressors | None
    missing: tuple[str, ...]
    alone: GainTest | None
    additional: GainTest | None
    selected: bool
    given: tuple[str, ...]


def fold_mask(n: int, blocks: int) -> np.ndarray:
    """True on half of `blocks` contiguous blocks of n samples, False on the other half, the halves drawn at random
    with a fixed seed (reproducible). Random, not alternating: alternate blocks of a periodic test (a sine) would
    fit on one range of phases and evaluate on another, i.e. extrapolate."""
    chosen = np.random.default_rng(FOLD_SEED).permutation(blocks)[: blocks // 2]
    return np.isin(np.arange(n) * blocks // n, chosen)


def _scaled(matrix: np.ndarray) -> np.ndarray:
    """Columns divided by their rms (better conditioned; a least-squares fit does not change); zero columns dropped."""
    scale = np.sqrt(np.mean(matrix**2, axis=0))
    keep = scale > 0
    return matrix[:, keep] / scale[keep]


def extend_base(base: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """The base columns with `columns` beside them, rescaled: what a family is tested beyond once another is given."""
    return _scaled(np.column_stack([base, columns]))


def _ridge(design: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least squares with a tiny ridge (RIDGE · n on the unit-rms columns): near-collinear columns (tanh at
    neighbouring scales) then get bounded coefficients instead of cancelling giants that explode out of sample."""
    gram = design.T @ design
    gram[np.diag_indices_from(gram)] += RIDGE * len(target)
    return np.linalg.solve(gram, design.T @ target)


def cross_fit_errors(target: np.ndarray, design: np.ndarray, fold: np.ndarray) -> np.ndarray:
    """Held-out errors of target ~ design: each fold predicted by the fit on the other."""
    if design.shape[1] == 0:
        return target.copy()
    errors = np.empty_like(target)
    for fit in (fold, ~fold):
        errors[~fit] = target[~fit] - design[~fit] @ _ridge(design[fit], target[fit])
    return errors


def gain_test(target: np.ndarray, base: np.ndarray, extra: np.ndarray, fold: np.ndarray) -> GainTest:
    """Out-of-sample explained variance of `extra` beyond `base` and the one-sided Diebold-Mariano p-value."""
    e_base = cross_fit_errors(target, base, fold)
    e_full = cross_fit_errors(target, _scaled(np.column_stack([base, extra])), fold)
    sse_base = float(np.sum(e_base**2))
    explained = 1 - float(np.sum(e_full**2)) / sse_base if sse_base > 0 else 0.0
    d = e_base**2 - e_full**2
    long_run, bandwidth = newey_west_variance(d)
    variance = max(long_run, float(np.var(d)))  # never claim more evidence than n independent samples
    n = len(d)
    if variance <= 0:
        statistic = 0.0 if np.mean(d) <= 0 else np.inf
        effective = float(n)
    else:
        statistic = float(np.mean(d) / np.sqrt(variance / n))
        effective = float(n * np.var(d) / variance)
    return GainTest(explained, float(stats.norm.sf(statistic)), statistic, effective, bandwidth)


def recalibration(signals: EffectSignals, model_inputs: dict[str, np.ndarray]) -> np.ndarray:
    """The recalibration columns, shape (n, 1 + inputs): predicted output and the model's input channels."""
    return _scaled(np.column_stack([signals.predicted, *model_inputs.values()]))


def family_threshold(alpha: float, testable: int) -> float:
    """The p-value below which a family counts as significant: Bonferroni over the `testable` families."""
    return alpha / max(testable, 1)


def rank_effects(
    signals: EffectSignals, families: list[Effect], base: np.ndarray, settings: DiagnosisSettings
) -> list[RankedFamily]:
    """Rank `families` on the residual measured - predicted beyond the `base` columns (see `recalibration` and the
    module docstring); selected ones first, then the others by what they explain alone, then the untestable."""
    residual = signals.measured - signals.predicted
    fold = fold_mask(len(residual), settings.blocks)
    testable = {f.name: f for f in families if not f.missing(signals)}
    regressors = {name: f.regressors(signals, settings) for name, f in testable.items()}
    alone = {name: gain_test(residual, base, r.matrix, fold) for name, r in regressors.items()}
    threshold = family_threshold(settings.alpha, len(testable))
    selected: list[str] = []
    additional: dict[str, GainTest] = {}
    given: dict[str, tuple[str, ...]] = {}
    remaining = list(testable)
    while remaining:
        tests = {name: gain_test(residual, base, regressors[name].matrix, fold) for name in remaining}
        for name in remaining:
            additional[name], given[name] = tests[name], tuple(selected)
        significant = [name for name in remaining if tests[name].p_value < threshold]
        if not significant:
            break
        best = max(significant, key=lambda name: tests[name].explained)
        selected.append(best)
        remaining.remove(best)
        base = extend_base(base, regressors[best].matrix)
    rest = sorted(remaining, key=lambda name: -alone[name].explained)
    ranked = [
        RankedFamily(testable[n], regressors[n], (), alone[n], additional[n], n in selected, given[n])
        for n in selected + rest
    ]
    ranked += [
        RankedFamily(f, None, f.missing(signals), None, None, False, ()) for f in families if f.name not in testable
    ]
    return ranked
