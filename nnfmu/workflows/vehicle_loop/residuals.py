"""Replay the virtual car on the lab's drive and compare it with the measured channels: per channel the mean shift,
peak and valley ratios, RMS ratio, NRMSE, rainflow pseudo-damage ratio and the PSD difference, on the record after
its settling time."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.cosim import CosimSettings
from nnfmu.data import Measurement
from nnfmu.validate import ChannelComparison, ValidationSettings, compare
from nnfmu.workflows.system import VirtualSystem

PSD_BAND = (0.5, 40.0)  # [Hz] where the PSD difference is read: the rig controller's band


def replay_system(system: VirtualSystem, drive: Measurement, step: float) -> Measurement:
    """Every output of the system co-simulated in memory on `drive` at the communication `step` [s] (master
    defaults)."""
    return system.cosimulate(drive, CosimSettings(step=step)).measurement


def on_record(result: Measurement, measured: Measurement, channels: list[str], settle: float) -> Measurement:
    """`channels` of `result` interpolated onto the measured time stamps from `settle` [s] after the record's start
    to the end of both."""
    start = measured.time[0] + settle
    keep = (measured.time >= start - 1e-12) & (measured.time <= result.time[-1] + 1e-12)
    time = measured.time[keep]
    return Measurement(
        time, {c: np.interp(time, result.time, result[c]) for c in channels}, {c: result.units[c] for c in channels}
    )


def settled(measured: Measurement, like: Measurement, channels: list[str]) -> Measurement:
    """The measured `channels` on the time stamps of `like` (taken from the record, not interpolated)."""
    rows = np.searchsorted(measured.time, like.time - 1e-12)
    return Measurement(
        like.time.copy(),
        {c: np.asarray(measured[c], dtype=float)[rows] for c in channels},
        {c: measured.units[c] for c in channels},
        source=measured.source,
    )


@dataclass(frozen=True)
class ChannelError:
    """One channel of the virtual car against the lab car (ratios [1]; mean shift in the channel's unit: virtual
    minus measured; psd_difference_db: rms over the band of 10 log10(PSD virtual / PSD measured))."""

    nrmse: float
    mean_shift: float
    peak_ratio: float
    valley_ratio: float
    rms_ratio: float
    damage_ratio: float
    psd_difference_db: float

    def to_dict(self) -> dict[str, float | None]:
        return {k: (float(v) if np.isfinite(v) else None) for k, v in self.__dict__.items()}


def _psd_difference(c: ChannelComparison) -> float:
    f = c.psd_reference.frequency
    band = (f >= PSD_BAND[0]) & (f <= PSD_BAND[1]) & (c.psd_reference.density > 0) & (c.psd_result.density > 0)
    if not band.any():
        return float("nan")
    ratio = 10 * np.log10(c.psd_result.density[band] / c.psd_reference.density[band])
    return float(np.sqrt(np.mean(ratio**2)))


def channel_errors(virtual: Measurement, measured: Measurement, channels: list[str]) -> dict[str, ChannelError]:
    """Each channel's `ChannelError` (virtual as the result, measured as the reference)."""
    found = {}
    for c in compare(virtual, measured, channels, ValidationSettings()):
        m = c.metrics
        found[c.name] = ChannelError(
            nrmse=m.nrmse,
            mean_shift=m.mean_shift,
            peak_ratio=m.peak_ratio,
            valley_ratio=m.valley_ratio,
            rms_ratio=m.rms_ratio,
            damage_ratio=m.pseudo_damage_ratio,
            psd_difference_db=_psd_difference(c),
        )
    return found
