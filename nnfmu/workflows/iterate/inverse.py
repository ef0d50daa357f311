"""The regularised inverse of the frequency response, and its application to response errors over a whole record.

Per frequency line inside the band, with the response channels weighted by W = diag(1 / RMS of each target channel)
so that channels in different units count alike: H⁺ = (Hwᴴ Hw + λ I)⁻¹ Hwᴴ W, Hw = W H. With as many or more targets
than actuators this is the weighted least-squares drive that best explains the responses; λ = (ε σ_max)², σ_max the
largest singular value of Hw over the band's lines (one Tikhonov term for the record), so lines and directions the
posts barely move (a car follows a slow post motion without any response to speak of) are damped instead of
amplified into a drifting drive.
"""

from __future__ import annotations

import numpy as np
from scipy.fft import irfft, next_fast_len, rfft, rfftfreq

from nnfmu.workflows.iterate.identify import Frf


def regularised_inverse(frf: Frf, weights: np.ndarray, regularisation: float, band: tuple[float, float]) -> np.ndarray:
    """H⁺ (k, m, p) [m / response unit] of `frf` per line (see the module docstring); `weights` (p,) [1/unit]."""
    k, p, m = frf.h.shape
    w = np.asarray(weights, dtype=float)
    hw = w[None, :, None] * frf.h
    inside = (frf.frequency >= band[0]) & (frf.frequency <= band[1])
    largest = np.linalg.svd(hw[inside], compute_uv=False)[:, 0].max(initial=0.0)
    good = inside & (np.abs(hw).max(axis=(1, 2)) > 0)
    gram = np.swapaxes(hw.conj(), 1, 2) @ hw + (regularisation * largest) ** 2 * np.eye(m)
    inverse = np.zeros((k, m, p), dtype=complex)
    inverse[good] = np.linalg.solve(gram[good], np.swapaxes(hw[good].conj(), 1, 2)) * w[None, None, :]
    return inverse


def apply_inverse(
    inverse: np.ndarray, frequency: np.ndarray, error: np.ndarray, dt: float, band: tuple[float, float]
) -> np.ndarray:
    """Drive correction (n, m) [m] for response `error` (n, p) sampled every `dt` [s]: H⁺ interpolated onto the
    record's FFT lines (real and imaginary parts, linearly), zero outside `band` [Hz]; the record is zero-padded to
    twice its length so the correction does not wrap around its ends."""
    n = error.shape[0]
    size = next_fast_len(2 * n)
    f = rfftfreq(size, dt)
    spectrum = rfft(error, size, axis=0)  # (lines, p)
    inside = (f >= band[0]) & (f <= band[1]) & (f <= frequency[-1])
    _, m, p = inverse.shape
    correction = np.zeros((len(f), m), dtype=complex)
    fi = f[inside]
    for j in range(m):
        for i in range(p):
            gain = np.interp(fi, frequency, inverse[:, j, i].real) + 1j * np.interp(
                fi, frequency, inverse[:, j, i].imag
            )
            correction[inside, j] += gain * spectrum[inside, i]
    return irfft(correction, size, axis=0)[:n]
