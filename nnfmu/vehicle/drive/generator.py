"""Four-post drive files from an ISO 8608 road: left/right tracks, rear axle delayed by wheelbase / speed, events.

Channels (all [m], posts under the wheels): actuator_fl_displacement, actuator_fr_displacement (front left/right)
and actuator_rl_displacement, actuator_rr_displacement (rear). The road is a closed loop of N points spaced
speed / sample_rate apart; at sample k the rear axle is at x = k * spacing and the front axle at x + wheelbase.
The front tracks are the rear tracks shifted by the wheelbase as a phase shift exp(i 2 pi n wheelbase) of their
spectra, which is exact for any wheelbase, including a fractional number of samples (no interpolation error), so
rear(t) = front(t - wheelbase / speed) holds to rounding. Events are evaluated at each axle's own positions and
the rig controller's band limit (`rig_filter`) is applied to each channel's spectrum on the loop. The loop is twice
the drive plus the wheelbase: the filter tails of an event (a few periods of the cut-off) fade in the unused half
instead of wrapping round into the drive, and the loop, so the road of a seed, does not depend on the road class,
the filters or the events.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.fft import irfft, next_fast_len, rfft, rfftfreq

from nnfmu.data import Measurement
from nnfmu.vehicle.drive.events import hits
from nnfmu.vehicle.drive.rig_filter import controller_gain
from nnfmu.vehicle.drive.road import CLASS_LEVELS, track_spectra
from nnfmu.vehicle.drive.settings import DriveSettings

CHANNELS = (
    "actuator_fl_displacement",
    "actuator_fr_displacement",
    "actuator_rl_displacement",
    "actuator_rr_displacement",
)
UNIT = "m"


def loop_points(settings: DriveSettings) -> int:
    """Points of the road loop: twice the drive plus the wheelbase, rounded up to a fast FFT length."""
    ahead = math.ceil(settings.wheelbase / settings.spacing)
    return next_fast_len(2 * (settings.samples + ahead), real=True)


def _events_on_track(settings: DriveSettings, side: str, positions: np.ndarray) -> np.ndarray:
    """Road height change [m] of every event in track `side` at loop `positions` [m]."""
    height = np.zeros_like(positions)
    for event in settings.events:
        if hits(event, side):
            centre = settings.speed * event.time + settings.wheelbase
            height += event.shape(positions - centre)
    return height


def generate_drive(settings: DriveSettings | None = None) -> Measurement:
    """A four-actuator drive file [m] for `settings` (default: class C at 20 m/s, 50 s at 1 kHz, 0.5-40 Hz).

    Raises DriveError naming the first bad setting or event (see `DriveSettings.check`).
    """
    settings = settings if settings is not None else DriveSettings()
    settings.check()
    points = loop_points(settings)
    n, left, right = track_spectra(settings, points)
    positions = np.arange(points) * settings.spacing
    gain = controller_gain(rfftfreq(points, 1.0 / settings.sample_rate), settings)
    to_front = np.exp(2j * np.pi * n * settings.wheelbase)
    channels: dict[str, np.ndarray] = {}
    weight = fade_in_weight(settings)
    for axle, shift, offset in (("f", to_front, settings.wheelbase), ("r", 1.0, 0.0)):
        for side, spectrum in (("l", left), ("r", right)):
            events = _events_on_track(settings, "left" if side == "l" else "right", positions + offset)
            track = irfft(gain * (spectrum * shift + rfft(events)), points)
            channels[f"actuator_{axle}{side}_displacement"] = track[: settings.samples] * weight
    return Measurement(
        time=np.arange(settings.samples) / settings.sample_rate,
        channels=channels,
        units={name: UNIT for name in CHANNELS},
        source=f"nnfmu drive generator (ISO 8608 class {settings.road_class}, {settings.speed:g} m/s, "
        f"seed {settings.seed})",
        notes=_notes(settings),
    )


def fade_in_weight(settings: DriveSettings) -> np.ndarray:
    """Weight of every sample: (1 - cos(pi t / fade_in)) / 2 over the fade-in, then 1."""
    t = np.arange(settings.samples) / settings.sample_rate
    if settings.fade_in == 0:
        return np.ones_like(t)
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(t / settings.fade_in, 0.0, 1.0))


def _notes(settings: DriveSettings) -> dict[str, str]:
    """Provenance of a generated drive, one readable line per setting."""
    low, high = settings.band
    return {
        "road": f"ISO 8608 class {settings.road_class}, Gd(0.1 cycles/m) = {CLASS_LEVELS[settings.road_class]:g} m^3, "
        f"w = 2, band {low:g}-{high:g} cycles/m, seed {settings.seed}",
        "vehicle": f"speed {settings.speed:g} m/s, wheelbase {settings.wheelbase:g} m, "
        f"track width {settings.track_width:g} m, coherence {settings.coherence}",
        "rig_filter": f"high-pass {settings.highpass} Hz, low-pass {settings.lowpass} Hz, zero-phase Butterworth "
        f"order {settings.filter_order}",
        "events": "; ".join(repr(event) for event in settings.events) or "none",
        "fade_in": f"{settings.fade_in:g} s raised cosine from rest" if settings.fade_in else "none",
    }
