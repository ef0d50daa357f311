"""Rig drives derived from a vehicle simulation's component deflections (the thesis's rig data design): the
bushing rig's four channels from a bushing's deflections, the damper dyno's stroke from the dampers' strokes.

ORIGIN.md: the desired rig signals follow the spectrum of the deflections the vehicle simulation produces, and their
peaks exceed the simulated peaks, so a network trained on the rig record is used only where it was trained. Per rig
channel (axial, radial, axial rotation, conical rotation) the design takes the simulated deflection of one or more
bushing elements of a result file (e.g. `bushing_fl_front_radial_displacement`), estimates its PSD about its mean
(Welch, then smoothed over a fraction of an octave; the elements' PSDs averaged), keeps it inside the rig
controller's band, synthesises a random-phase multisine with that PSD (`random_motion`) and scales it about the
simulated working point (the mean) so that its excursions above and below reach at least `margin` times the simulated
ones on each side, and its largest rate `margin` times the simulated deflection's: whichever needs most sets the
scale. The car's motion is peakier than a random-phase multisine (conical rate crest factor 6 against 4), so with
the deflection alone setting the scale the rates of a held-out car motion reached 1.24-1.26 of the networks'
envelope, and the conical torque network's NRMSE was 5.05 % instead of 4.56 % (`bench/bushing_drive.py`, 50 s).

Where the record starts matters because the bushing's friction remembers it: Jenkins elements that never slip over
the motion act as springs anchored where the bushing was last relaxed. The vehicle reference starts every bushing
relaxed at its static deflection (the first sample of the result, the same for every drive), so by default the rig
record starts there too (the specimen mounted and settled at the car's static deflection) and moves to the working
point over the fade; a drive faded in from zero deflection leaves the non-slipping elements anchored at zero, which
shifted the front LCA bushing's radial network by 10.8 N on average (the force's rms about its mean: 20 N) along a
held-out car motion (`bench/bushing_drive.py --unsettled --duration 20`, before the rate margin).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy.signal import welch

from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.rigs.bushing_rig import CHANNELS
from nnfmu.data.rigs.excitation import Motion, preload, random_motion
from nnfmu.errors import SettingsError
from nnfmu.kinds import BUSHING, DAMPER

# The rig controller's pass band [Hz] by rig: the bushing rig's lab drive reaches 40 Hz; a servo-hydraulic damper
# dyno follows small strokes to about 100 Hz, and the car moves its dampers there (wheel hop ~12 Hz, the road's
# short waves above): the hysteresis network trained on the lab drive (flat in velocity over 1-20 Hz) was off by
# 2.1-2.2 % in spindle acceleration in the road test, trained on the car's spectrum up to 100 Hz by 1.8-1.9 %
# (bench/road_test.py, 50 s).
RIG_BANDS: dict[str, tuple[float, float]] = {"bushing": (0.5, 40.0), "damper": (0.5, 100.0)}
WELCH_SECONDS = 4.0  # Welch segment length: 0.25 Hz resolution, enough below the band's 0.5 Hz edge
SMOOTHING_OCTAVES = 1 / 3  # width of the fractional-octave average applied to the Welch estimate


@dataclass(frozen=True)
class DriveDesign:
    """How a vehicle-derived drive is designed: `margin` [1] over the simulated excursions on each side of the
    working point; `band` [Hz] the rig controller's pass band (the lab drive's 0.5-40 Hz); `fade` [s] at each end;
    `fit_sensors`: size every transducer's range to the test (else the rig's default transducers); `headroom` [1]:
    full scale over the test's peak when sizing; `settled`: the record starts at the first element's initial
    deflection in the result (its static deflection), else at zero deflection."""

    margin: float = 1.2
    band: tuple[float, float] = (0.5, 40.0)
    fade: float = 0.5
    fit_sensors: bool = True
    headroom: float = 1.25
    settled: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.margin) and self.margin >= 1.0):
            raise SettingsError(
                f"margin must be a number >= 1 (the drive's peaks over the simulated ones), got {self.margin!r}"
            )
        low, high = self.band
        if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
            raise SettingsError(f"band must be (low, high) [Hz] with 0 <= low < high, got {self.band!r}")
        if not (math.isfinite(self.fade) and self.fade > 0):
            raise SettingsError(f"fade must be a positive time [s], got {self.fade!r}")
        if not (math.isfinite(self.headroom) and self.headroom >= 1.0):
            raise SettingsError(f"headroom must be a number >= 1, got {self.headroom!r}")


@dataclass(frozen=True)
class SampledSpectrum:
    """A PSD given at `frequency` [Hz] (linear interpolation between lines, end values held), zero outside
    [`f_low`, `f_high`]."""

    frequency: np.ndarray
    density: np.ndarray
    f_low: float
    f_high: float

    def psd(self, f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, dtype=float)
        inside = (f >= self.f_low) & (f <= self.f_high)
        return np.where(inside, np.interp(f, self.frequency, self.density), 0.0)

    def describe(self) -> dict:
        return {
            "type": "smoothed Welch PSD of the simulated deflection",
            "f_low_Hz": self.f_low,
            "f_high_Hz": self.f_high,
            "welch_segment_s": WELCH_SECONDS,
            "smoothing_octaves": SMOOTHING_OCTAVES,
        }


def deflection_psd(x: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSD of `x` about its mean (segments of WELCH_SECONDS or the whole record), smoothed over
    SMOOTHING_OCTAVES: frequency [Hz] and density [unit²/Hz]."""
    segment = min(len(x), int(round(WELCH_SECONDS * rate)))
    f, p = welch(np.asarray(x, dtype=float), fs=rate, nperseg=segment, detrend="constant")
    return f, octave_smoothed(f, p, SMOOTHING_OCTAVES)


def octave_smoothed(f: np.ndarray, p: np.ndarray, octaves: float) -> np.ndarray:
    """Mean of `p` over [f·2^(-octaves/2), f·2^(octaves/2)] at every line f > 0 (the 0 Hz line is kept)."""
    sums = np.concatenate([[0.0], np.cumsum(p)])
    half = 2.0 ** (octaves / 2)
    lo = np.searchsorted(f, f / half, side="left")
    hi = np.searchsorted(f, f * half, side="right")
    smoothed = (sums[hi] - sums[lo]) / np.maximum(hi - lo, 1)
    return np.where(f > 0, smoothed, p)


@dataclass(frozen=True)
class Extremes:
    """A signal's mean, rms about the mean, lowest and highest value (its unit)."""

    mean: float
    rms: float
    min: float
    max: float

    @staticmethod
    def of(x: np.ndarray) -> "Extremes":
        x = np.asarray(x, dtype=float)
        mean = float(np.mean(x))
        return Extremes(mean, float(np.sqrt(np.mean((x - mean) ** 2))), float(np.min(x)), float(np.max(x)))


@dataclass(frozen=True)
class ChannelDesign:
    """One rig channel's design: the simulated deflection it comes from (per element), the working point, the
    target envelope [low, high] (margin over the simulated excursions), the drive's statistics and its scale."""

    key: str
    unit: str
    simulated: dict[str, Extremes]
    share_outside_band: float
    start: float
    working_point: float
    target_low: float
    target_high: float
    designed: Extremes
    rms_over_simulated: float

    def to_dict(self) -> dict:
        return {
            "channel": self.key,
            "unit": self.unit,
            "simulated": {element: asdict(e) for element, e in self.simulated.items()},
            "simulated_variance_outside_band": self.share_outside_band,
            "start": self.start,
            "working_point": self.working_point,
            "target_low": self.target_low,
            "target_high": self.target_high,
            "designed": asdict(self.designed),
            "designed_rms_over_simulated_rms": self.rms_over_simulated,
        }


@dataclass(frozen=True)
class VehicleDrive:
    """A vehicle-derived drive: the rig motion of every channel and how each was designed."""

    motions: dict[str, Motion]
    channels: dict[str, ChannelDesign]
    source: str
    elements: tuple[str, ...]
    design: DriveDesign

    def describe(self) -> dict:
        return {
            "type": "vehicle-derived target-spectrum random (ORIGIN.md: rig data design)",
            "source": self.source,
            "elements": list(self.elements),
            "design": asdict(self.design) | {"band": list(self.design.band)},
            "start": "settled at the simulated initial deflection (the car's static position), then faded to the "
            "working point"
            if self.design.settled
            else "at rest (zero deflection), faded to the working point",
            "peak_control": "random part scaled about the working point (the simulated mean) so that its excursions "
            "above and below reach at least margin x the simulated ones; the side that needs more "
            "sets the scale",
            "combination": "all channels driven at once, each with its own random phases (independent): every "
            "network sees its own channel only, so each gets the whole record"
            if len(self.channels) > 1
            else "one channel",
            "channels": {key: c.to_dict() for key, c in self.channels.items()},
        }


def deflection(source: Measurement, element: str, key: str) -> np.ndarray:
    """The simulated position of channel `key` of bushing `element`, checked for its SI unit."""
    channel = CHANNELS[key]
    name = f"{element}_{channel.position}"
    if name not in source:
        raise DataError(
            f"{source.source}: no channel {name!r} for the {key} deflection of {element} (bushing "
            f"channels there: {', '.join(n for n in source.names if BUSHING.owns(n)) or 'none'})"
        )
    unit = source.units.get(name)
    if unit != channel.position_unit:
        raise DataError(
            f"{source.source}: channel {name!r} is in {unit!r}; a {key} deflection needs a unit that "
            f"converts to {channel.position_unit!r}"
        )
    return np.asarray(source[name], dtype=float)


def damper_stroke(source: Measurement, element: str) -> np.ndarray:
    """The simulated stroke [m] of damper `element` (its `<element>_displacement` channel), checked for its unit."""
    name = f"{element}_displacement"
    if name not in source:
        raise DataError(
            f"{source.source}: no channel {name!r} for the stroke of {element} (damper channels there: "
            f"{', '.join(n for n in source.names if DAMPER.owns(n)) or 'none'})"
        )
    if source.units.get(name) != "m":
        raise DataError(
            f"{source.source}: channel {name!r} is in {source.units.get(name)!r}; a damper stroke needs "
            "a unit that converts to 'm'"
        )
    return np.asarray(source[name], dtype=float)


def _channel(
    source: Measurement,
    elements: Sequence[str],
    key: str,
    rate: float,
    n: int,
    rng: np.random.Generator,
    design: DriveDesign,
) -> tuple[Motion, ChannelDesign]:
    """Design the drive of bushing channel `key` from the simulated deflections of `elements`."""
    simulated = {element: deflection(source, element, key) for element in elements}
    return derive_channel(source, simulated, key, CHANNELS[key].position_unit, rate, n, rng, design)


def derive_channel(
    source: Measurement,
    simulated: dict[str, np.ndarray],
    key: str,
    unit: str,
    rate: float,
    n: int,
    rng: np.random.Generator,
    design: DriveDesign,
) -> tuple[Motion, ChannelDesign]:
    """Design one rig channel's drive (`n` samples at `rate` [Hz], in `unit`) from the simulated positions of one or
    more elements (element -> samples of `source`)."""
    elements = list(simulated)
    stats = {element: Extremes.of(x) for element, x in simulated.items()}
    low, high = design.band
    spectra = [deflection_psd(x, 1 / source.sample_period) for x in simulated.values()]
    f = spectra[0][0]
    density = np.mean([p for _, p in spectra], axis=0)
    total = float(np.trapezoid(density, f))
    inside = (f >= low) & (f <= high)
    if total <= 0 or not np.any(density[inside] > 0):
        raise DataError(
            f"{source.source}: the {key} deflection of {', '.join(elements)} does not move inside the "
            f"rig band {low:g}-{high:g} Hz; there is nothing to derive a drive from"
        )
    band_share = float(np.trapezoid(np.where(inside, density, 0.0), f)) / total
    spectrum = SampledSpectrum(f, density, low, high)
    unit_motion = random_motion(spectrum, rate, n, rng, min(design.fade, n / rate / 4))
    centre = float(np.mean([s.mean for s in stats.values()]))
    target_high = max(s.mean + design.margin * (s.max - s.mean) for s in stats.values())
    target_low = min(s.mean + design.margin * (s.min - s.mean) for s in stats.values())
    rate_peak = max(float(np.max(np.abs(np.gradient(x, source.sample_period)))) for x in simulated.values())
    scale = max(
        (target_high - centre) / float(np.max(unit_motion.x)),
        (centre - target_low) / -float(np.min(unit_motion.x)),
        design.margin * rate_peak / float(np.max(np.abs(unit_motion.v))),
    )
    start = float(simulated[elements[0]][0]) if design.settled else 0.0
    shift = preload(centre - start, rate, n, min(design.fade, n / rate / 4))
    working_point = Motion(start + shift.x, shift.v, shift.a)
    random_part = unit_motion.scaled(scale)
    motion = Motion(working_point.x + random_part.x, working_point.v + random_part.v, working_point.a + random_part.a)
    designed = Extremes.of(motion.x)
    simulated_rms = max(s.rms for s in stats.values())
    return motion, ChannelDesign(
        key=key,
        unit=unit,
        simulated=stats,
        share_outside_band=1.0 - band_share,
        start=start,
        working_point=centre,
        target_low=target_low,
        target_high=target_high,
        designed=designed,
        rms_over_simulated=designed.rms / simulated_rms if simulated_rms > 0 else float("inf"),
    )


def design_vehicle_drive(
    source: Measurement, elements: Sequence[str], rate: float, n: int, seed: int, design: DriveDesign = DriveDesign()
) -> VehicleDrive:
    """Rig motions of all four bushing channels (`n` samples at `rate` [Hz]) derived from the deflections of the
    bushing `elements` (e.g. ['bushing_fl_front']) in the simulation result `source`; `seed` picks the phases.

    Raises DataError naming the file and channel when a deflection is missing, has the wrong unit or does not move.
    """
    elements = tuple(elements)
    if not elements:
        raise SettingsError("name at least one bushing element (e.g. bushing_fl_front) to derive the drive from")
    streams = np.random.SeedSequence([seed, 2]).spawn(len(CHANNELS))
    motions: dict[str, Motion] = {}
    channels: dict[str, ChannelDesign] = {}
    for key, stream in zip(CHANNELS, streams):
        motions[key], channels[key] = _channel(source, elements, key, rate, n, np.random.default_rng(stream), design)
    return VehicleDrive(motions, channels, source.source, elements, design)


def design_damper_drive(
    source: Measurement, elements: Sequence[str], rate: float, n: int, seed: int, design: DriveDesign
) -> VehicleDrive:
    """The damper dyno's stroke (`n` samples at `rate` [Hz]) derived from the strokes of the damper `elements` (e.g.
    ['damper_fl', 'damper_rl']) in the simulation result `source`; it starts at rest (it follows the dyno's sine
    series) and fades to the simulated working point. DataError names a missing, misunited or still stroke."""
    elements = tuple(elements)
    if not elements:
        raise SettingsError("name at least one damper element (e.g. damper_fl) to derive the drive from")
    if design.band[1] >= rate / 2:
        raise SettingsError(
            f"band {design.band[0]:g}-{design.band[1]:g} Hz reaches the Nyquist frequency of "
            f"{rate:g} Hz sampling; sample faster or narrow the band"
        )
    simulated = {element: damper_stroke(source, element) for element in elements}
    rng = np.random.default_rng(np.random.SeedSequence([seed, 3]))
    motion, channel = derive_channel(
        source, simulated, "displacement", "m", rate, n, rng, replace(design, settled=False)
    )
    return VehicleDrive({"displacement": motion}, {"displacement": channel}, source.source, elements, design)
