"""A multi-axis bushing rig: drive signals per channel, transducers, and the measured record of the bushing truth."""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from nnfmu.data.rigs.excitation import (
    MIN_SINE_CYCLES,
    Motion,
    SineLevel,
    SpectrumShape,
    random_motion,
    sine_series,
    sine_series_cycles,
)
from nnfmu.data.rigs.sensors import Sensor, record
from nnfmu.errors import SettingsError
from nnfmu.physics.bushing import IWAN_ELEMENTS, IWAN_SPAN, BushingChannelTruth, BushingParams


@dataclass(frozen=True)
class BushingChannel:
    """Names of one channel's recorded signals and its SI units."""

    position: str
    rate: str
    force: str
    position_unit: str
    rate_unit: str
    force_unit: str


# BushingParams field -> recorded channels (ORIGIN.md: axial and radial force, axial and conical torque).
CHANNELS: dict[str, BushingChannel] = {
    "axial": BushingChannel("axial_displacement", "axial_velocity", "axial_force", "m", "m/s", "N"),
    "radial": BushingChannel("radial_displacement", "radial_velocity", "radial_force", "m", "m/s", "N"),
    "axial_rotation": BushingChannel("axial_rotation", "axial_angular_velocity", "axial_torque", "rad", "rad/s", "N.m"),
    "conical_rotation": BushingChannel(
        "conical_rotation", "conical_angular_velocity", "conical_torque", "rad", "rad/s", "N.m"
    ),
}
UNITS = {
    name: unit
    for ch in CHANNELS.values()
    for name, unit in ((ch.position, ch.position_unit), (ch.rate, ch.rate_unit), (ch.force, ch.force_unit))
}


def _default_vehicle_range() -> dict[str, float]:
    # Peak deflections of a front LCA bushing in durability driving (m, rad): ±2.5 mm, ±1.2 mm, ±7°, ±2.3°.
    return {"axial": 2.5e-3, "radial": 1.2e-3, "axial_rotation": 0.12, "conical_rotation": 0.04}


def _default_sensors() -> dict[str, Sensor]:
    s = Sensor
    return {
        "axial_displacement": s(0.01, 0.0005),
        "axial_velocity": s(0.5, 0.001),
        "axial_force": s(10e3, 0.001),
        "radial_displacement": s(0.005, 0.0005),
        "radial_velocity": s(0.25, 0.001),
        "radial_force": s(25e3, 0.001),
        "axial_rotation": s(0.5, 0.0005),
        "axial_angular_velocity": s(10.0, 0.001),
        "axial_torque": s(250.0, 0.001),
        # a multi-axis load cell: the conical torque uses a small part of its range, so it is noisy (ORIGIN.md)
        "conical_rotation": s(0.2, 0.0005),
        "conical_angular_velocity": s(4.0, 0.001),
        "conical_torque": s(2000.0, 0.001),
    }


@dataclass(frozen=True)
class BushingRig:
    """The rig's drive design and transducers.

    "lab": the lab's schedule per channel: the dynamic-stiffness series (every `sine_frequencies` at every
    `sine_amplitudes` fraction of the vehicle range, `lab_sine_cycles` cycles each, as a lab characterises a bushing),
    then for the rest of the record an independent Gaussian random signal whose PSD follows `lab_shape` (flat to the
    body modes, then falling to the rig controller's 40 Hz cut-off) with peaks `lab_margin` times the vehicle range,
    so a network never has to extrapolate (ORIGIN.md). "random": a different band-limited shape with peaks
    `random_margin` times the vehicle range, for held-out data inside the lab envelope. "sine": the dynamic-stiffness
    series alone, as many cycles per level as the record holds.
    """

    vehicle_range: dict[str, float] = field(default_factory=_default_vehicle_range)
    lab_shape: SpectrumShape = SpectrumShape(f_low=0.5, f_corner=3.0, f_high=40.0, slope=2.0)
    lab_margin: float = 1.25
    random_shape: SpectrumShape = SpectrumShape(f_low=0.5, f_corner=10.0, f_high=30.0, slope=2.0)
    random_margin: float = 0.9
    sine_frequencies: tuple[float, ...] = (1.0, 2.0, 5.0, 10.0, 15.0, 20.0)
    sine_amplitudes: tuple[float, ...] = (0.25, 0.5, 1.0)
    lab_sine_cycles: int = MIN_SINE_CYCLES + 1
    rest: float = 0.2
    fade: float = 0.5
    sensors: dict[str, Sensor] = field(default_factory=_default_sensors)

    def motion(self, key: str, excitation: str, rate: float, n: int, rng: np.random.Generator) -> tuple[Motion, dict]:
        """Drive signal of channel `key` (a BushingParams field) with `n` samples at `rate` [Hz]."""
        reach = self.vehicle_range[key]
        levels = [SineLevel(frac * reach, f) for f in self.sine_frequencies for frac in self.sine_amplitudes]
        if excitation == "sine":
            cycles = sine_series_cycles(levels, n / rate, self.rest)
            sine, described = sine_series(levels, cycles, rate, self.rest)
            return sine.fit(n), {"type": "sine series", "levels": described}
        if excitation != "lab":
            return self._random(self.random_shape, self.random_margin, reach, rate, n, rng, "band-limited random")
        sine, described = sine_series(levels, self.lab_sine_cycles, rate, self.rest)
        remaining = n - len(sine)
        if remaining < 2 * self.fade * rate:
            series = len(sine) / rate
            raise SettingsError(
                f"bushing 'lab' excitation of {n / rate:g} s: its dynamic-stiffness series takes {series:g} s and the "
                f"random part after it at least {2 * self.fade:g} s; choose a duration of at least "
                f"{series + 2 * self.fade:g} s, or the 'random' excitation"
            )
        random, random_described = self._random(
            self.lab_shape, self.lab_margin, reach, rate, remaining, rng, "target-spectrum random"
        )
        parts = [
            {"type": "sine series", "levels": described, "start_s": 0.0, "end_s": len(sine) / rate},
            dict(random_described, start_s=len(sine) / rate, end_s=n / rate),
        ]
        return Motion.concatenate([sine, random]), {"type": "lab schedule", "parts": parts}

    def _random(
        self,
        shape: SpectrumShape,
        margin: float,
        reach: float,
        rate: float,
        n: int,
        rng: np.random.Generator,
        kind: str,
    ) -> tuple[Motion, dict]:
        """`n` samples of random motion following `shape`, its peak `margin` times the vehicle range `reach`."""
        motion = random_motion(shape, rate, n, rng, min(self.fade, n / rate / 4))
        motion = motion.scaled(margin * reach / np.max(np.abs(motion.x)))
        return motion, {
            "type": kind,
            "position_psd_shape": shape.describe(),
            "vehicle_range": reach,
            "peak_over_vehicle_range": margin,
            "peak_rate": float(np.max(np.abs(motion.v))),
            "rms_position": float(np.sqrt(np.mean(motion.x**2))),
        }


def run_bushing_rig(
    params: BushingParams,
    effects: tuple[str, ...],
    rig: BushingRig,
    rate: float,
    n: int,
    excitation: str,
    noise: float,
    seed: int,
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Time [s], recorded channels (SI) and the truth's description of the excitation of one rig run."""
    motions: dict[str, Motion] = {}
    drives: dict[str, dict] = {}
    streams = np.random.SeedSequence([seed, 0]).spawn(len(CHANNELS))
    for key, stream in zip(CHANNELS, streams):
        motions[key], drives[key] = rig.motion(key, excitation, rate, n, np.random.default_rng(stream))
    channels = record(true_signals(params, effects, motions, rate), rig.sensors, noise, seed)
    return np.arange(n) / rate, channels, {"drives": drives, **RUN_NOTES}


# How every bushing rig run is simulated and recorded (written into the truth file's excitation).
RUN_NOTES = {
    "friction_realisation": {"jenkins_elements": IWAN_ELEMENTS, "slip_span_in_x2": list(IWAN_SPAN)},
    "integration": "exact for positions linear between samples (exponential Maxwell update, play operators)",
    "recorded_rate": "true rate plus rate-transducer noise",
    "channels_independent": "each channel driven and modelled on its own; no cross-coupling",
}


def true_signals(
    params: BushingParams, effects: tuple[str, ...], motions: dict[str, Motion], rate: float
) -> dict[str, np.ndarray]:
    """Position, rate and force of every channel (a BushingParams field in `motions`) before the transducers."""
    true: dict[str, np.ndarray] = {}
    for key, motion in motions.items():
        channel = CHANNELS[key]
        force, _ = BushingChannelTruth(getattr(params, key), effects).simulate(1 / rate, motion.x)
        true.update({channel.position: motion.x, channel.rate: motion.v, channel.force: force})
    return true


def describe_params(params: BushingParams) -> dict:
    """Every channel's parameters with units."""
    return {f.name: getattr(params, f.name).describe() for f in fields(params)}
