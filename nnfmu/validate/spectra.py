"""Power spectral density by Welch's method, cut at the frequency band a road test simulator excites."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import welch


@dataclass(frozen=True)
class Spectrum:
    """One-sided PSD: `frequency` [Hz] shape (k,), `density` [unit^2/Hz] shape (k,), mean removed per segment."""

    frequency: np.ndarray
    density: np.ndarray


def welch_psd(signal: np.ndarray, dt: float, fmax: float = 50.0, resolution: float = 0.25) -> Spectrum:
    """Welch PSD of `signal` sampled every `dt` [s] up to `fmax` [Hz]: Hann segments of 1/`resolution` s, 50 % overlap.

    The segment is shortened to the signal's length for short records. The mean is removed (it is reported as the
    mean shift), so the PSD integrates to the signal's variance.
    """
    if not dt > 0:
        raise ValueError(f"sample period must be positive, got {dt!r} s")
    if not (fmax > 0 and resolution > 0):
        raise ValueError(f"fmax and resolution must be positive, got {fmax!r} Hz and {resolution!r} Hz")
    nperseg = min(len(signal), max(8, int(round(1.0 / (resolution * dt)))))
    frequency, density = welch(
        np.asarray(signal, dtype=float),
        fs=1.0 / dt,
        window="hann",
        nperseg=nperseg,
        detrend="constant",
        scaling="density",
    )
    keep = frequency <= fmax
    return Spectrum(frequency=frequency[keep], density=density[keep])
