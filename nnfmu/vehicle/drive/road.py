"""ISO 8608 random road profiles: class levels, displacement PSD, left/right track coherence, spectral synthesis.

ISO 8608 gives the one-sided displacement PSD of a track as Gd(n) = Gd(n0) (n / n0)^-w with n0 = 0.1 cycles/m and
w = 2; the class levels Gd(n0) used here are the geometric means of the classes, 16e-6 m^3 for class A and four
times more for each class after it (B 64e-6, C 256e-6, ... H 4.2e-3).

Synthesis: the sum of sinusoids at the FFT frequencies n_k = k / (N dx) inside the band, amplitude
sqrt(2 Gd(n_k) dn) (so every realisation has exactly the class PSD) and seeded random phases, evaluated with one
inverse FFT. The profile is periodic over its N points, i.e. a closed loop of road.

Track coherence: the right track is gamma(n) Z1 + sqrt(1 - gamma^2) Z2 with Z1 the left track and Z2 an independent
one of the same PSD, so the cross-spectrum is gamma(n) Gd(n) and the magnitude-squared coherence gamma^2. For the
"isotropic" model the road surface is statistically the same in every direction; with Gd ~ n^-2 its 2-D spectrum
falls as |kappa|^-3 and two tracks b apart have gamma(n) = x K1(x), x = 2 pi n b (K1: modified Bessel function of the
second kind): 1 for long waves, 0.5 at n = 0.2 / b, and 0.006 at n = 1 / b.
"""

from __future__ import annotations

import numpy as np
from scipy.fft import rfftfreq
from scipy.special import k1

from nnfmu.vehicle.drive.settings import ROAD_CLASSES, DriveSettings

REFERENCE_FREQUENCY = 0.1  # n0 [cycles/m]
WAVINESS = 2.0  # w [1]
CLASS_A_LEVEL = 16e-6  # Gd(n0) of class A [m^3], geometric mean of the class
CLASS_STEP = 4.0  # each class has four times the PSD of the one before

CLASS_LEVELS: dict[str, float] = {name: CLASS_A_LEVEL * CLASS_STEP**i for i, name in enumerate(ROAD_CLASSES)}


def displacement_psd(n: np.ndarray, road_class: str) -> np.ndarray:
    """One-sided displacement PSD Gd(n) [m^3] of an ISO 8608 class at spatial frequencies `n` [cycles/m] (> 0)."""
    return CLASS_LEVELS[road_class] * (np.asarray(n, dtype=float) / REFERENCE_FREQUENCY) ** -WAVINESS


def track_coherence(n: np.ndarray, track_width: float, model: str) -> np.ndarray:
    """Coherence gamma(n) [1] of two tracks `track_width` [m] apart (cross-spectrum / auto-spectrum), n > 0."""
    n = np.asarray(n, dtype=float)
    if model == "identical":
        return np.ones_like(n)
    if model == "independent":
        return np.zeros_like(n)
    x = 2 * np.pi * n * track_width
    return x * k1(x)


def _amplitudes(n: np.ndarray, settings: DriveSettings, resolution: float) -> np.ndarray:
    """Sinusoid amplitude [m] at each frequency: sqrt(2 Gd dn) inside the band, 0 outside (and at n = 0)."""
    low, high = settings.band
    inside = (n >= low) & (n <= high) & (n > 0)
    amplitude = np.zeros_like(n)
    amplitude[inside] = np.sqrt(2 * displacement_psd(n[inside], settings.road_class) * resolution)
    return amplitude


def track_spectra(settings: DriveSettings, points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Spatial frequencies [cycles/m] and the rfft spectra of the left and right tracks on `points` samples.

    The grid spacing is `settings.spacing`; `irfft(spectrum, points)` gives the profile [m]. Phases come from
    `numpy.random.default_rng(settings.seed)`, so a seed gives the same road at every class (only scaled).
    """
    spacing = settings.spacing
    n = rfftfreq(points, spacing)
    amplitude = _amplitudes(n, settings, 1.0 / (points * spacing))
    rng = np.random.default_rng(settings.seed)
    phase_left, phase_right = rng.uniform(0.0, 2 * np.pi, size=(2, n.size))
    # irfft of (points / 2) * A * exp(i phi) is sum(A cos(2 pi n x + phi)) for the bins between 0 and Nyquist.
    scale = points / 2 * amplitude
    left = scale * np.exp(1j * phase_left)
    independent = scale * np.exp(1j * phase_right)
    gamma = np.zeros_like(n)
    gamma[n > 0] = track_coherence(n[n > 0], settings.track_width, settings.coherence)
    right = gamma * left + np.sqrt(1.0 - gamma**2) * independent
    if points % 2 == 0:  # the Nyquist bin of an even grid holds a real cosine only: leave it out
        left[-1] = right[-1] = 0.0
    return n, left, right
