"""Correlation statistics of the residual tests: sample auto/cross-correlation, Bartlett bands, Ljung-Box, and the
Newey-West long-run variance used wherever samples are autocorrelated.

Why Bartlett bands: under "no relation" the sample cross-correlation of two series has variance
(1/n)·Σ_k ρ_a(k)·ρ_b(k) (Bartlett, 1946), which is 1/n only when one of them is white. Rig inputs are strongly
autocorrelated and so is a model residual, so the band is widened by that sum instead of assuming whiteness.
"""

from __future__ import annotations

import numpy as np
from scipy import stats


def standardise(x: np.ndarray) -> np.ndarray:
    """x minus its mean, divided by its standard deviation (a constant series stays zero)."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    scale = np.std(x)
    return x / scale if scale > 0 else x


def _fft_correlate(a: np.ndarray, b: np.ndarray, max_lag: int) -> np.ndarray:
    """sum_t a[t+k]·b[t] / n for k = -max_lag..max_lag (a, b already standardised, same length n)."""
    n = len(a)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(a, size) * np.conj(np.fft.rfft(b, size))
    full = np.fft.irfft(spectrum, size)
    lags = np.concatenate([full[size - max_lag :], full[: max_lag + 1]])
    return lags / n


def cross_correlation(a: np.ndarray, b: np.ndarray, max_lag: int) -> tuple[np.ndarray, np.ndarray]:
    """(lags -max_lag..max_lag, r) with r[k] = corr(a[t+k], b[t]), normalised by the full-length variances."""
    return np.arange(-max_lag, max_lag + 1), _fft_correlate(standardise(a), standardise(b), max_lag)


def autocorrelation(a: np.ndarray, max_lag: int) -> np.ndarray:
    """ρ(0..max_lag) of `a`."""
    return _fft_correlate(standardise(a), standardise(a), max_lag)[max_lag:]


def bartlett_variance(a: np.ndarray, b: np.ndarray, horizon: int) -> float:
    """Variance of a sample cross-correlation of unrelated a and b: (1/n)·Σ_{|k|<=horizon} ρ_a(k)·ρ_b(k).

    Never below the white-noise value 1/n, so the band is never narrower than the classical ±z/√n.
    """
    ra, rb = autocorrelation(a, horizon), autocorrelation(b, horizon)
    total = ra[0] * rb[0] + 2 * float(np.sum(ra[1:] * rb[1:]))
    return max(total, 1.0) / len(a)


def ljung_box(a: np.ndarray, max_lag: int) -> tuple[float, float]:
    """(Q, p) of the Ljung-Box test that ρ(1..max_lag) of `a` are all zero; Q ~ χ²(max_lag) for white noise."""
    n = len(a)
    rho = autocorrelation(a, max_lag)[1:]
    q = n * (n + 2) * float(np.sum(rho**2 / (n - np.arange(1, max_lag + 1))))
    return q, float(stats.chi2.sf(q, max_lag))


def newey_west_variance(d: np.ndarray) -> tuple[float, int]:
    """(long-run variance of d, bandwidth) with a Bartlett kernel.

    The bandwidth is the first lag where |ρ_d| falls below 2/√n (where d stops being correlated), at least the usual
    ⌊4 (n/100)^(2/9)⌋ and at most n/10; strongly autocorrelated d gets a wide window and so a larger variance.
    """
    n = len(d)
    centred = d - np.mean(d)
    gamma0 = float(np.mean(centred**2))
    cap = max(1, n // 10)
    rho = autocorrelation(centred, cap) if gamma0 > 0 else np.zeros(cap + 1)
    below = np.nonzero(np.abs(rho[1:]) < 2 / np.sqrt(n))[0]
    first = int(below[0]) + 1 if below.size else cap
    bandwidth = int(min(cap, max(first, np.floor(4 * (n / 100) ** (2 / 9)))))
    weights = 1 - np.arange(1, bandwidth + 1) / (bandwidth + 1)
    variance = gamma0 * (1 + 2 * float(np.sum(weights * rho[1 : bandwidth + 1])))
    return max(variance, 0.0), bandwidth
