"""Classical residual tests with confidence bands: whiteness, cross-correlation with each input, and the nonlinear
correlation tests of Billings & Voon (1986) for unmodelled nonlinearity.

For a model that has captured everything but noise, the residual ε is white and independent of the inputs u:
- whiteness: ρ_εε(k) = 0 for k = 1..L (Ljung-Box test, band ±z/√n per lag);
- cross-correlation: ρ_uε(k) = 0 for |k| <= L (unmodelled memory or dynamics of u);
- ρ_u²'ε(k) = 0 (residual vs squared input: an unmodelled even nonlinearity in u);
- ρ_u²'ε²(k) = 0 (squared residual vs squared input: input-dependent error size);
- ρ_ε(εu)(k) = 0 for k = 1..L+1 (residual vs the lagged residual-input product: unmodelled nonlinear noise terms).
A correlation test's statistic is the largest |ρ| over its lags; its band is z·σ with σ² the Bartlett variance
(see `correlation`) and z Bonferroni-corrected over the lags, so a test fails at most at rate `alpha` under the null.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from nnfmu.diagnosis.correlation import autocorrelation, bartlett_variance, cross_correlation, ljung_box
from nnfmu.diagnosis.settings import DiagnosisSettings


@dataclass(frozen=True)
class ResidualTest:
    """One residual test: the correlations over `lags`, the statistic and its band, the p-value and the verdict."""

    name: str
    description: str
    statistic: float
    band: float
    p_value: float
    passed: bool
    lags: tuple[int, ...]
    values: tuple[float, ...]

    @property
    def verdict(self) -> str:
        return "pass" if self.passed else "fail"

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "description": self.description,
            "statistic": self.statistic,
            "band": self.band,
            "p_value": self.p_value,
            "verdict": self.verdict,
            "lags": list(self.lags),
            "values": list(self.values),
        }


def whiteness_test(residual: np.ndarray, settings: DiagnosisSettings) -> ResidualTest:
    """Ljung-Box test of ρ_εε(1..max_lag) = 0; band ±z_{1-α/2}/√n per lag, for plotting."""
    q, p = ljung_box(residual, settings.max_lag)
    rho = autocorrelation(residual, settings.max_lag)[1:]
    band = float(stats.norm.isf(settings.alpha / 2) / np.sqrt(len(residual)))
    return ResidualTest(
        "whiteness",
        f"residual autocorrelation, lags 1..{settings.max_lag} (Ljung-Box Q = {q:.4g})",
        q,
        band,
        p,
        p >= settings.alpha,
        tuple(range(1, settings.max_lag + 1)),
        tuple(float(r) for r in rho),
    )


def correlation_test(
    name: str, description: str, a: np.ndarray, b: np.ndarray, lags: range, settings: DiagnosisSettings
) -> ResidualTest:
    """Test corr(a[t+k], b[t]) = 0 for every k in `lags` by the largest |ρ| against a Bonferroni-Bartlett band."""
    reach = max(abs(lags.start), abs(lags.stop - 1))
    all_lags, rho = cross_correlation(a, b, reach)
    chosen = np.isin(all_lags, np.array(lags))
    values = rho[chosen]
    sigma = float(np.sqrt(bartlett_variance(a, b, max(len(a) // 10, reach))))
    m = len(values)
    statistic = float(np.max(np.abs(values)))
    p_value = float(min(1.0, m * 2 * stats.norm.sf(statistic / sigma)))
    band = float(stats.norm.isf(settings.alpha / (2 * m)) * sigma)
    return ResidualTest(
        name,
        description,
        statistic,
        band,
        p_value,
        p_value >= settings.alpha,
        tuple(int(k) for k in all_lags[chosen]),
        tuple(float(r) for r in values),
    )


def residual_tests(
    residual: np.ndarray, inputs: dict[str, np.ndarray], settings: DiagnosisSettings
) -> list[ResidualTest]:
    """Whiteness, then for every input channel the cross-correlation and the three Billings-Voon tests."""
    lag = settings.max_lag
    both = range(-lag, lag + 1)
    tests = [whiteness_test(residual, settings)]
    squared = residual**2
    for name, u in inputs.items():
        u2 = u**2
        tests += [
            correlation_test(
                f"cross_correlation[{name}]", f"residual vs {name} over lags -{lag}..{lag}", residual, u, both, settings
            ),
            correlation_test(
                f"residual_vs_squared_input[{name}]",
                f"residual vs {name}² (Billings-Voon)",
                residual,
                u2,
                both,
                settings,
            ),
            correlation_test(
                f"squared_residual_vs_squared_input[{name}]",
                f"residual² vs {name}² (Billings-Voon)",
                squared,
                u2,
                both,
                settings,
            ),
            correlation_test(
                f"residual_vs_residual_input_product[{name}]",
                f"residual vs lagged residual·{name}, lags 1..{lag + 1} (Billings-Voon)",
                residual,
                residual * u,
                range(1, lag + 2),
                settings,
            ),
        ]
    return tests
