"""Zero-phase low-pass of measured input channels: a rig's transducer noise removed above its drive band.

Why: a stop (play) operator of a noisy position sees reversals the motion never made, so its state wanders with the
noise; a network trained on such features learns a friction and stiffness that are biased where it later runs on
a simulation's clean signals. Rig drives end at the controller's cut-off (40 Hz, the thesis's rigs); a Butterworth
low-pass of order ORDER run forward and backward (no phase lag) well above it leaves the motion and removes most of
the noise. Used by training only: the FMU receives the vehicle's signals as they are.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from scipy.signal import butter, sosfiltfilt

from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement

ORDER = 4


def lowpass_channels(m: Measurement, channels: Iterable[str], cutoff: float | None) -> Measurement:
    """`m` with `channels` low-passed at `cutoff` [Hz] forward and backward (Butterworth, order ORDER); None: `m`."""
    if cutoff is None:
        return m
    nyquist = 0.5 / m.sample_period
    if not 0 < cutoff < nyquist:
        raise DataError(f"{m.source}: input low-pass cut-off {cutoff!r} Hz must lie between 0 and {nyquist:g} Hz")
    sos = butter(ORDER, cutoff, fs=1.0 / m.sample_period, output="sos")
    padding = 3 * (2 * len(sos) + 1)
    if len(m.time) <= padding:
        raise DataError(f"{m.source}: {len(m.time)} samples are too few to low-pass (more than {padding} needed)")
    filtered = dict(m.channels)
    notes = dict(m.notes)
    for name in dict.fromkeys(channels):
        if name not in m.channels:
            raise DataError(f"{m.source}: no channel {name!r} to low-pass (has {m.names})")
        filtered[name] = sosfiltfilt(sos, np.asarray(m.channels[name], dtype=float))
        notes[f"lowpass:{name}"] = f"{name!r} low-passed at {cutoff:g} Hz (Butterworth order {ORDER}, zero phase)"
    return Measurement(time=m.time, channels=filtered, units=dict(m.units), source=m.source, notes=notes)
