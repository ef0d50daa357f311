"""What a rig run is asked for: kind, effects, excitation, sampling, noise and seed, checked once here."""

from __future__ import annotations

import math
from dataclasses import dataclass

from nnfmu.errors import SettingsError
from nnfmu.kinds import kind_of_rig
from nnfmu.physics.effects import DEFAULT_EFFECTS, EFFECTS

KINDS = ("damper", "bushing")
DAMPER_TYPES = ("passive", "mr", "cdc")  # passive valve, magnetorheological (coil voltage), CDC (valve current)
EXCITATIONS = ("lab", "random", "sine", "vehicle")
VEHICLE_EXCITATION = "vehicle"  # a drive derived from a vehicle result (`vehicle_rig`), never self-made

DEFAULT_DURATION: dict[str, float] = {"damper": 70.0, "bushing": 60.0}  # s
# Records whose schedule needs its own default length [s], by (kind, excitation). The bushing's lab record: its
# dynamic-stiffness series (26.6 s), then 53.4 s of random drive, which covers the car's bushing motions better than
# 60 s of random alone did; at 90 s training's blocks would hold the series' 20 Hz full-range levels out of training
# (docs/characterise.md).
SCHEDULE_DURATION: dict[tuple[str, str], float] = {("bushing", "lab"): 80.0}
MIN_SAMPLE_RATE = 100.0  # Hz: the drives reach 40 Hz, and the recorder has no anti-alias filter
MAX_SAMPLES = 10_000_000  # per record (2.8 h at 1 kHz): a rig run holds a dozen arrays of this length in memory


@dataclass(frozen=True)
class RigOptions:
    """Settings of one simulated rig run.

    `sample_rate` [Hz]; `duration` [s] (None: 70 s damper, 80 s bushing lab record, 60 s other bushing records);
    `seed` makes runs reproducible; `noise` multiplies the realistic sensor noise (0: exact truth values, no noise and
    no quantisation); `effects` (None: the kind's defaults, (): only the base characteristic); `excitation`: "lab"
    (damper: sine series at standard peak velocities, then band-limited random; bushing: the dynamic-stiffness sine
    series, then target-spectrum random beyond the vehicle range), "random" (only band-limited random, for held-out
    test data), "sine" (only the sine series) or "vehicle" (a drive derived from a vehicle simulation's deflections,
    see `vehicle_rig`; damper: the sine series, then the derived random).
    `damper_type` (damper only): "passive", "mr" (magnetorheological, commanded by coil voltage) or "cdc"
    (continuously controlled valve, commanded by valve current); the semi-active types add a lab-like command signal.
    """

    sample_rate: float = 1000.0
    duration: float | None = None
    seed: int = 0
    noise: float = 1.0
    effects: tuple[str, ...] | None = None
    excitation: str = "lab"
    damper_type: str = "passive"


def check_kind(kind: str) -> str:
    """Return `kind` if it is a known rig kind, else raise SettingsError naming the valid ones."""
    if kind not in KINDS:
        raise SettingsError(f"unknown rig kind {kind!r}; valid kinds: {', '.join(KINDS)}")
    return kind


def effect_set(kind: str, damper_type: str = "passive") -> str:
    """The key of `kind`'s effects in `EFFECTS`: the kind, or the semi-active damper's own ("mr_damper", ...)."""
    check_kind(kind)
    if damper_type not in DAMPER_TYPES:
        raise SettingsError(f"unknown damper type {damper_type!r}; valid types: {', '.join(DAMPER_TYPES)}")
    if damper_type == "passive":
        return kind
    if damper_type not in kind_of_rig(kind).rig_types:
        raise SettingsError(f"damper type {damper_type!r} is for the damper dyno, not the {kind} rig")
    return f"{damper_type}_damper"


def resolve_effects(kind: str, effects: tuple[str, ...] | None, damper_type: str = "passive") -> tuple[str, ...]:
    """The effects switched on for `kind` (and damper type), in canonical order; an unknown name: SettingsError naming
    the valid ones."""
    key = effect_set(kind, damper_type)
    valid = EFFECTS[key]
    if effects is None:
        return DEFAULT_EFFECTS[key]
    if isinstance(effects, str):
        raise SettingsError(f"effects must be a tuple of names, not the string {effects!r}")
    unknown = [name for name in effects if name not in valid]
    if unknown:
        what = kind if damper_type == "passive" else f"{damper_type} {kind}"
        raise SettingsError(
            f"unknown {what} effect(s) {', '.join(map(repr, unknown))}; valid {what} effects: {', '.join(valid)}"
        )
    return tuple(name for name in valid if name in effects)


def resolve_duration(kind: str, options: RigOptions) -> float:
    """The run's duration [s]: the option, or the default of the kind and excitation (SCHEDULE_DURATION), else of the
    kind."""
    if options.duration is not None:
        return float(options.duration)
    return SCHEDULE_DURATION.get((check_kind(kind), options.excitation), DEFAULT_DURATION[kind])


def check_options(kind: str, options: RigOptions) -> None:
    """Raise SettingsError naming the bad option value, else return None."""
    check_kind(kind)
    resolve_effects(kind, options.effects, options.damper_type)
    if options.excitation not in EXCITATIONS:
        raise SettingsError(f"unknown excitation {options.excitation!r}; valid excitations: {', '.join(EXCITATIONS)}")
    if options.damper_type != "passive" and options.excitation == VEHICLE_EXCITATION:
        raise SettingsError(
            f"the {options.damper_type} damper dyno has no vehicle-derived drive; use the lab, random "
            "or sine excitation"
        )
    if not (math.isfinite(options.sample_rate) and options.sample_rate >= MIN_SAMPLE_RATE):
        raise SettingsError(
            f"sample_rate must be at least {MIN_SAMPLE_RATE:g} Hz (the drives reach 40 Hz), got {options.sample_rate!r}"
        )
    duration = resolve_duration(kind, options)
    if not (math.isfinite(duration) and duration * options.sample_rate >= 16):
        raise SettingsError(
            f"duration {duration!r} s gives fewer than 16 samples at {options.sample_rate:g} Hz; choose a longer one"
        )
    samples = duration * options.sample_rate
    if samples > MAX_SAMPLES:
        raise SettingsError(
            f"duration {duration:g} s at {options.sample_rate:g} Hz gives {samples:.4g} samples, more "
            f"than the limit of {MAX_SAMPLES} per record; record in shorter parts"
        )
    if not (math.isfinite(options.noise) and options.noise >= 0):
        raise SettingsError(f"noise must be a non-negative multiplier of realistic sensor noise, got {options.noise!r}")
    if not isinstance(options.seed, int) or options.seed < 0:
        raise SettingsError(f"seed must be a non-negative integer, got {options.seed!r}")
