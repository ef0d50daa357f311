"""What a diagnosis reports: per-effect evidence in words and numbers, and the whole diagnosis as JSON-safe data."""

from __future__ import annotations

import math
from dataclasses import dataclass

from nnfmu.diagnosis.ranking import GainTest, RankedFamily, family_threshold
from nnfmu.diagnosis.residual_tests import ResidualTest
from nnfmu.diagnosis.stop_reading import StopReading, p_words


def _finite(x: float | None) -> float | None:
    """JSON has no inf/NaN: map them to None."""
    return None if x is None or not math.isfinite(x) else float(x)


@dataclass(frozen=True)
class EffectEvidence:
    """One effect's standing: variance explained out of sample alone and beyond the effects ranked above, the
    p-value of the latter (Diebold-Mariano, autocorrelation-robust), significance, regressors and missing channels."""

    rank: int
    name: str
    description: str
    testable: bool
    explained_variance: float | None
    additional_explained_variance: float | None
    p_value: float | None
    significant: bool
    effective_samples: float | None
    given: tuple[str, ...]
    regressors: tuple[str, ...]
    missing_channels: tuple[str, ...]
    evidence: str

    def to_dict(self) -> dict:
        return {
            "rank": self.rank,
            "name": self.name,
            "description": self.description,
            "testable": self.testable,
            "explained_variance": _finite(self.explained_variance),
            "additional_explained_variance": _finite(self.additional_explained_variance),
            "p_value": _finite(self.p_value),
            "significant": self.significant,
            "effective_samples": _finite(self.effective_samples),
            "given": list(self.given),
            "regressors": list(self.regressors),
            "missing_channels": list(self.missing_channels),
            "evidence": self.evidence,
        }


def _evidence_text(item: RankedFamily, threshold: float) -> str:
    if item.alone is None or item.additional is None or item.regressors is None:
        return f"cannot be tested: needs {', '.join(item.missing)}, which the measurement lacks"
    alone, extra = item.alone, item.additional
    given = "beyond the recalibrated model" + (f" and {', '.join(item.given)}" if item.given else "")
    text = (
        f"explains {alone.explained:.1%} of the residual variance out of sample alone, {extra.explained:.1%} "
        f"{given} ({p_words(extra.p_value)}, Diebold-Mariano on held-out errors, effective sample size "
        f"{extra.effective_samples:.0f}); "
    )
    text += "significant" if item.selected else f"not significant at the family-wise threshold {threshold:.2g}"
    text += f"; regressors: {item.regressors.note}"
    return text


def effect_evidence(ranked: list[RankedFamily], alpha: float) -> list[EffectEvidence]:
    """The ranking as evidence records, rank 1 first; `alpha` is the family-wise significance level."""
    threshold = family_threshold(alpha, sum(item.regressors is not None for item in ranked))
    out = []
    for rank, item in enumerate(ranked, start=1):
        test: GainTest | None = item.additional
        proxy = item.regressors.missing if item.regressors is not None else ()
        out.append(
            EffectEvidence(
                rank=rank,
                name=item.family.name,
                description=item.family.description,
                testable=item.regressors is not None,
                explained_variance=item.alone.explained if item.alone else None,
                additional_explained_variance=test.explained if test else None,
                p_value=test.p_value if test else None,
                significant=item.selected,
                effective_samples=test.effective_samples if test else None,
                given=item.given,
                regressors=item.regressors.names if item.regressors is not None else (),
                missing_channels=item.missing or proxy,
                evidence=_evidence_text(item, threshold),
            )
        )
    return out


@dataclass(frozen=True)
class Diagnosis:
    """The residual tests, the effect ranking, the verdict and the measurements that would help, for one output.

    `residual_rms` in the output's SI unit; `recalibration_explained`: fraction of the residual variance that a
    re-tuned gain and a linear term in the model's inputs explain out of sample (the base every effect must beat);
    each effect's explained variances are fractions of what remains after that recalibration. `stop_reading`: the
    shape of the residual after reversals, which names the stop-operator family (play or pre-sliding seal friction;
    None without a displacement).
    """

    source: str
    output: str
    model_inputs: tuple[str, ...]
    samples: int
    sample_period: float
    residual_rms: float
    recalibration_explained: float
    tests: tuple[ResidualTest, ...]
    ranking: tuple[EffectEvidence, ...]
    consistent_with_noise: bool
    unknown_to_model: tuple[str, ...]
    missing_measurements: tuple[str, ...]
    summary: str
    stop_reading: StopReading | None = None

    @property
    def significant(self) -> list[EffectEvidence]:
        return [e for e in self.ranking if e.significant]

    def test(self, name: str) -> ResidualTest:
        for t in self.tests:
            if t.name == name:
                return t
        raise KeyError(f"no residual test {name!r}; tests: {', '.join(t.name for t in self.tests)}")

    def effect(self, name: str) -> EffectEvidence:
        for e in self.ranking:
            if e.name == name:
                return e
        raise KeyError(f"no effect {name!r} in the ranking; effects: {', '.join(e.name for e in self.ranking)}")

    def to_dict(self) -> dict:
        return {
            "source": self.source,
            "output": self.output,
            "model_inputs": list(self.model_inputs),
            "samples": self.samples,
            "sample_period_s": self.sample_period,
            "residual_rms": self.residual_rms,
            "recalibration_explained": self.recalibration_explained,
            "consistent_with_noise": self.consistent_with_noise,
            "summary": self.summary,
            "unknown_to_model": list(self.unknown_to_model),
            "missing_measurements": list(self.missing_measurements),
            "tests": [t.to_dict() for t in self.tests],
            "ranking": [e.to_dict() for e in self.ranking],
            "stop_reading": self.stop_reading.to_dict() if self.stop_reading is not None else None,
        }
