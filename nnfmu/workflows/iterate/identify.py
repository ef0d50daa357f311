"""System identification: H1 frequency responses from drives to responses per frequency line, with coherence.

Spectra come from scipy.signal.csd (Welch: Hann segments of 1/resolution s, 50 % overlap, means removed). With drive
spectra S_xx (m x m) and response-drive spectra S_yx (p x m) per line, H1 = S_yx S_xx⁻¹ (least squares over the
segments: the response's noise averages out, the drive is known exactly), and the multiple coherence of response i
with all drives, γ²_i = (H S_xx Hᴴ)_ii / S_yy,ii, says how much of its power they explain (1: all, linearly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import csd, welch


@dataclass(frozen=True)
class Spectra:
    """Summed cross spectra of drive records: `frequency` (k,) [Hz], `sxx` (k, m, m), `syx` (k, p, m), `syy` (k, p);
    densities times record length [unit²·s/Hz], so records of different lengths add by their weight."""

    frequency: np.ndarray
    sxx: np.ndarray
    syx: np.ndarray
    syy: np.ndarray

    def __add__(self, other: Spectra) -> Spectra:
        return Spectra(self.frequency, self.sxx + other.sxx, self.syx + other.syx, self.syy + other.syy)


@dataclass(frozen=True)
class Frf:
    """H1 estimate `h` (k, p, m) [response unit / m] at `frequency` (k,) [Hz] and each response's multiple
    coherence `coherence` (k, p) [1]."""

    frequency: np.ndarray
    h: np.ndarray
    coherence: np.ndarray


def cross_spectra(drive: np.ndarray, response: np.ndarray, dt: float, resolution: float) -> Spectra:
    """Spectra of one record: `drive` (n, m) [m] and `response` (n, p) sampled every `dt` [s]."""
    n, m = drive.shape
    p = response.shape[1]
    options = {"fs": 1.0 / dt, "window": "hann", "nperseg": min(n, round(1.0 / (resolution * dt)))}
    options["detrend"] = "constant"
    frequency, _ = welch(drive[:, 0], **options)
    weight = n * dt
    sxx = np.empty((len(frequency), m, m), dtype=complex)
    syx = np.empty((len(frequency), p, m), dtype=complex)
    syy = np.empty((len(frequency), p))
    for j in range(m):
        for k in range(m):
            sxx[:, j, k] = csd(drive[:, k], drive[:, j], **options)[1]  # E[X_j conj(X_k)]
        for i in range(p):
            syx[:, i, j] = csd(drive[:, j], response[:, i], **options)[1]  # E[Y_i conj(X_j)]
    for i in range(p):
        syy[:, i] = welch(response[:, i], **options)[1]
    return Spectra(frequency, sxx * weight, syx * weight, syy * weight)


def estimate_frf(spectra: Spectra) -> Frf:
    """H1 = S_yx S_xx⁻¹ and the multiple coherence per line, all lines at once (a line whose S_xx is singular, such
    as 0 Hz of detrended records: H = 0, coherence 0)."""
    k, p, m = spectra.syx.shape
    sxx = spectra.sxx
    sigma = np.linalg.svd(sxx, compute_uv=False)  # (k, m), largest first
    good = (sigma[:, 0] > 0) & (sigma[:, -1] > 1e-12 * sigma[:, 0])
    h = np.zeros((k, p, m), dtype=complex)
    h[good] = np.linalg.solve(np.swapaxes(sxx[good], 1, 2), np.swapaxes(spectra.syx[good], 1, 2)).swapaxes(1, 2)
    explained = np.real(np.einsum("lij,ljk,lik->li", h, sxx, h.conj()))
    syy = spectra.syy
    coherence = np.divide(explained, syy, out=np.zeros((k, p)), where=syy > 0)
    return Frf(spectra.frequency, h, np.clip(coherence, 0.0, 1.0))
