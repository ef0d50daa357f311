"""Compare chosen channels of a result with a reference measurement on one time base."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.units import base_name
from nnfmu.validate.damage import MAX_SLOPE
from nnfmu.validate.spectra import Spectrum, welch_psd
from nnfmu.validate.summary import ChannelMetrics, channel_metrics


class ValidationError(DataError):
    """A result and reference cannot be compared: a missing channel, a unit mismatch, no common time span."""


@dataclass(frozen=True)
class ValidationSettings:
    """How channels are compared.

    `basquin_slope` is the S-N exponent m for every channel (5 suits forces and torques); `slopes` overrides it per
    channel name or per quantity (`{"displacement": 3.0}`), a channel name winning over its quantity. PSDs run
    Welch with `psd_resolution` [Hz] up to `fmax` [Hz]. The time-history plot shows `window` = (start, end) [s] if
    given, else `window_length` [s] centred on the reference's global peak |x|.
    """

    basquin_slope: float = 5.0
    slopes: Mapping[str, float] = field(default_factory=dict)
    fmax: float = 50.0
    psd_resolution: float = 0.25
    window_length: float = 5.0
    window: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        named = {"Basquin slope m": self.basquin_slope} | {
            f"Basquin slope for {k!r}": v for k, v in self.slopes.items()
        }
        for what, value in named.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= MAX_SLOPE:
                raise ValidationError(f"{what} must be a number in (0, {MAX_SLOPE:g}], got {value!r}")
        if not (self.fmax > 0 and self.psd_resolution > 0 and self.window_length > 0):
            raise ValidationError(
                f"fmax, psd_resolution and window_length must be positive, got {self.fmax!r} Hz, "
                f"{self.psd_resolution!r} Hz, {self.window_length!r} s"
            )
        if self.window is not None and not self.window[0] < self.window[1]:
            raise ValidationError(f"window start must be before its end, got {self.window!r} s")

    def slope_for(self, channel: str) -> float:
        """The Basquin slope of `channel`: its own override, else its quantity's, else `basquin_slope`."""
        if channel in self.slopes:
            return float(self.slopes[channel])
        return float(self.slopes.get(quantity_of(channel), self.basquin_slope))


@dataclass(frozen=True)
class ChannelComparison:
    """One channel compared: metrics, the aligned arrays (shape (n,)) and both PSDs, for plots and the report."""

    name: str
    unit: str
    quantity: str
    basquin_slope: float
    metrics: ChannelMetrics
    time: np.ndarray
    result: np.ndarray
    reference: np.ndarray
    window: tuple[float, float]
    psd_result: Spectrum
    psd_reference: Spectrum


def quantity_of(channel: str) -> str:
    """Physical quantity from a channel's base name (`axial_force` -> `force`); the name itself if none is known."""
    return base_name(channel) or channel


def compare(
    result: Measurement, reference: Measurement, channels: Sequence[str], settings: ValidationSettings | None = None
) -> list[ChannelComparison]:
    """Compare `channels` of `result` with `reference`; the result is interpolated onto the reference's time stamps
    within the span both cover when their time axes differ."""
    settings = settings or ValidationSettings()
    if not channels:
        raise ValidationError(f"no channels to compare between {result.source} and {reference.source}")
    for name in channels:
        _check_channel(name, result, reference)
    keep, result_on = _common_time(result, reference)
    time = reference.time[keep]
    return [
        _compare_channel(name, time, result_on(name), reference[name][keep], reference, settings) for name in channels
    ]


def common_channels(result: Measurement, reference: Measurement) -> list[str]:
    """Channels both measurements recorded, in the reference's order; rates the loader derived (noted as
    `derived:<name>` in either measurement's notes) are left out, as they only repeat a compared channel."""
    return [
        name
        for name in reference.names
        if name in result and not any(f"derived:{name}" in m.notes for m in (result, reference))
    ]


def _check_channel(name: str, result: Measurement, reference: Measurement) -> None:
    for m in (result, reference):
        if name not in m:
            raise ValidationError(f"{m.source}: no channel {name!r} (has: {', '.join(m.names)})")
        if not np.all(np.isfinite(m[name])):
            raise ValidationError(f"{m.source}: channel {name!r} holds NaN or infinite values")
    unit_result, unit_reference = result.units.get(name, ""), reference.units.get(name, "")
    if unit_result != unit_reference:
        raise ValidationError(
            f"channel {name!r}: unit {unit_result!r} in {result.source} but {unit_reference!r} in {reference.source}"
        )


def _common_time(result: Measurement, reference: Measurement) -> tuple[np.ndarray, Callable[[str], np.ndarray]]:
    """A mask of the reference samples inside both time spans, and a function giving a result channel on them."""
    if len(result.time) == len(reference.time) and np.allclose(
        result.time, reference.time, rtol=0, atol=1e-9 * reference.sample_period
    ):
        return np.ones(len(reference.time), dtype=bool), lambda name: np.asarray(result[name], dtype=float)
    tol = 1e-9 * reference.sample_period
    start, end = max(result.time[0], reference.time[0]) - tol, min(result.time[-1], reference.time[-1]) + tol
    keep = (reference.time >= start) & (reference.time <= end)
    time = reference.time[keep]
    if len(time) < 2:
        raise ValidationError(
            f"{result.source} ({result.time[0]:g}..{result.time[-1]:g} s) and {reference.source} "
            f"({reference.time[0]:g}..{reference.time[-1]:g} s) share fewer than 2 reference samples"
        )
    return keep, lambda name: np.interp(time, result.time, np.asarray(result[name], dtype=float))


def _plot_window(
    time: np.ndarray, reference: np.ndarray, settings: ValidationSettings, name: str
) -> tuple[float, float]:
    t0, t1 = float(time[0]), float(time[-1])
    if settings.window is not None:
        start, end = max(settings.window[0], t0), min(settings.window[1], t1)
        if not start < end:
            raise ValidationError(f"channel {name!r}: window {settings.window!r} s lies outside {t0:g}..{t1:g} s")
        return start, end
    peak_time = float(time[np.argmax(np.abs(reference))])
    half = settings.window_length / 2
    start = min(max(peak_time - half, t0), max(t1 - settings.window_length, t0))
    return start, min(start + settings.window_length, t1)


def _compare_channel(
    name: str,
    time: np.ndarray,
    result: np.ndarray,
    reference: np.ndarray,
    reference_measurement: Measurement,
    settings: ValidationSettings,
) -> ChannelComparison:
    reference = np.asarray(reference, dtype=float)
    slope = settings.slope_for(name)
    dt = reference_measurement.sample_period
    return ChannelComparison(
        name=name,
        unit=reference_measurement.units.get(name, ""),
        quantity=quantity_of(name),
        basquin_slope=slope,
        metrics=channel_metrics(result, reference, slope),
        time=time,
        result=result,
        reference=reference,
        window=_plot_window(time, reference, settings, name),
        psd_result=welch_psd(result, dt, settings.fmax, settings.psd_resolution),
        psd_reference=welch_psd(reference, dt, settings.fmax, settings.psd_resolution),
    )
