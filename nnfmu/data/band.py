"""The frequency band a record excites: the frequency below which a channel holds nearly all its power.

A network knows a component only where its rig record moved it, in frequency as much as in amplitude: a bushing
trained on a rig whose controller stops at 40 Hz answers a 50 Hz test by extrapolation even at an amplitude the
record reached. Every exported model carries its inputs' bands, so a report can say so per test point.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import welch

BAND_POWER_SHARE = 0.99  # a band's upper edge: the frequency below which the channel holds this share of its power
SEGMENT_SECONDS = 4.0  # Welch segments (0.25 Hz bins), shorter records in one segment


def excited_band(signal: np.ndarray, sample_period: float, share: float = BAND_POWER_SHARE) -> float:
    """Upper edge [Hz] of the band holding `share` of `signal`'s power, its mean removed (Welch's estimate); 0 Hz for a
    signal that does not move."""
    if not 0 < share < 1:
        raise ValueError(f"the power share {share!r} must lie in (0, 1)")
    frequency, power = _spectrum(signal, sample_period)
    total = float(np.sum(power))
    if not total > 0:
        return 0.0
    return float(frequency[np.searchsorted(np.cumsum(power), share * total)])


def power_above(signal: np.ndarray, sample_period: float, edge: float) -> float:
    """The share [1] of `signal`'s power (mean removed, Welch's estimate) above `edge` [Hz]; 0 for a signal that does
    not move. A record holds 1 - BAND_POWER_SHARE above its own band's edge; a run that holds much more there drives
    the network at frequencies its record did not."""
    if not (math.isfinite(edge) and edge >= 0):
        raise ValueError(f"band edge {edge!r} Hz must be a finite frequency >= 0")
    frequency, power = _spectrum(signal, sample_period)
    total = float(np.sum(power))
    return float(np.sum(power[frequency > edge]) / total) if total > 0 else 0.0


def _spectrum(signal: np.ndarray, sample_period: float) -> tuple[np.ndarray, np.ndarray]:
    """Welch's one-sided power spectrum of `signal` less its mean: frequencies [Hz] and powers (segments of
    SEGMENT_SECONDS, a shorter signal in one)."""
    x = np.asarray(signal, dtype=float)
    if x.ndim != 1 or len(x) < 2 or not np.all(np.isfinite(x)):
        raise ValueError(f"a band needs a finite 1-D signal of at least 2 samples, got shape {x.shape}")
    if not (math.isfinite(sample_period) and sample_period > 0):
        raise ValueError(f"sample period {sample_period!r} s must be a finite number > 0")
    segment = min(len(x), max(2, int(round(SEGMENT_SECONDS / sample_period))))
    return welch(x, fs=1.0 / sample_period, nperseg=segment, detrend="constant")
