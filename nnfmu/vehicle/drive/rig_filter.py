"""The rig controller's band limit on drive signals: a zero-phase Butterworth high-pass and low-pass.

A servo-hydraulic rig controller removes the mean and slow drift of a drive signal and cannot follow content above
its band (the thesis's controller: 40 Hz). nnfmu applies the gain |H(f)| of a Butterworth filter of order `order`
(cut-off = the -3 dB frequency) with zero phase, in the frequency domain: events keep their times and the rear
channels stay exact delayed copies of the front ones. Defaults: high-pass 0.5 Hz, low-pass 40 Hz, order 4.
"""

from __future__ import annotations

import numpy as np

from nnfmu.vehicle.drive.settings import DriveSettings


def controller_gain(frequencies: np.ndarray, settings: DriveSettings) -> np.ndarray:
    """Gain [1] of the rig controller's band limit at `frequencies` [Hz] (>= 0); 1 where both cut-offs are off."""
    f = np.asarray(frequencies, dtype=float)
    gain = np.ones_like(f)
    power = 2 * settings.filter_order
    if settings.lowpass is not None:
        gain /= np.sqrt(1.0 + (f / settings.lowpass) ** power)
    if settings.highpass is not None:
        with np.errstate(divide="ignore"):
            gain /= np.sqrt(1.0 + (settings.highpass / f) ** power)
    return gain
