"""Settings of the standard component tests: the damper's characteristic series and the bushing's dynamic-stiffness
grid, each checked (finite, positive, bounded) before any test runs."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from nnfmu.data.rigs import BushingRig
from nnfmu.errors import SettingsError

# Peak velocities [m/s] of the characteristic test (the dyno's standard series, Dixon) and its stroke amplitude [m].
PEAK_VELOCITIES = (0.05, 0.1, 0.2, 0.3, 0.5, 0.8, 1.0, 1.5)
STROKE_AMPLITUDE = 0.025
# Frequencies [Hz] and amplitudes (fractions of the channel's vehicle range) of the dynamic-stiffness grid.
FREQUENCIES = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)
AMPLITUDE_FRACTIONS = (0.25, 0.5, 1.0)
# Peak deflection of each bushing channel in a car [m or rad]: what the amplitude fractions scale.
VEHICLE_RANGE: dict[str, float] = dict(BushingRig().vehicle_range)
MAX_SETTLE_CYCLES = 50
MIN_SAMPLES_PER_CYCLE = 8  # a first-harmonic fit needs the cycle resolved
MAX_TEST_SAMPLES = 20_000_000  # all tests together, checked before the first runs
MAX_TESTS = 2000  # test points together (each opens the FMU once)
MAX_COMMAND_LEVELS = 20


def _positive(values: tuple[float, ...], what: str, unit: str) -> tuple[float, ...]:
    values = tuple(float(v) for v in values)
    if not values:
        raise SettingsError(f"{what}: give at least one value")
    for v in values:
        if not (math.isfinite(v) and v > 0):
            raise SettingsError(f"{what}: {v!r} {unit} must be a finite number > 0")
    if len(set(values)) != len(values):
        raise SettingsError(f"{what}: {values} repeats a value")
    return tuple(sorted(values))


def _cycles(value: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SETTLE_CYCLES:
        raise SettingsError(f"{what}: {value!r} must be a whole number from 0 to {MAX_SETTLE_CYCLES}")
    return value


@dataclass(frozen=True)
class DamperTestSettings:
    """The characteristic test: a sine of `stroke` amplitude [m] per peak velocity [m/s] (frequency v/(2π·stroke)),
    `settle_cycles` cycles (the first ramped in) before the measured one; a semi-active damper at each of `commands`
    (in its command's unit; None: `command_levels` levels across the command input's training envelope); a
    `temperature` input held at `temperature` [K]."""

    peak_velocities: tuple[float, ...] = PEAK_VELOCITIES
    stroke: float = STROKE_AMPLITUDE
    settle_cycles: int = 2
    commands: tuple[float, ...] | None = None
    command_levels: int = 5
    temperature: float = 293.15

    def __post_init__(self) -> None:
        object.__setattr__(self, "peak_velocities", _positive(self.peak_velocities, "peak velocities", "m/s"))
        _positive((self.stroke,), "stroke amplitude", "m")
        _positive((self.temperature,), "test temperature", "K")
        _cycles(self.settle_cycles, "damper settle cycles")
        if self.commands is not None:
            levels = tuple(float(c) for c in self.commands)
            if not levels or len(levels) > MAX_COMMAND_LEVELS or not all(math.isfinite(c) for c in levels):
                raise SettingsError(f"command levels {self.commands}: give 1 to {MAX_COMMAND_LEVELS} finite values")
            object.__setattr__(self, "commands", tuple(sorted(set(levels))))
        if isinstance(self.command_levels, bool) or not 2 <= self.command_levels <= MAX_COMMAND_LEVELS:
            raise SettingsError(f"command levels: {self.command_levels!r} must be from 2 to {MAX_COMMAND_LEVELS}")


@dataclass(frozen=True)
class BushingTestSettings:
    """Dynamic stiffness: a sine per frequency [Hz] x amplitude (fraction of the channel's `VEHICLE_RANGE`),
    `settle_cycles` before the measured one; the quasi-static loop: a sine at `quasi_static_frequency` [Hz] at the
    largest amplitude, one cycle settling."""

    frequencies: tuple[float, ...] = FREQUENCIES
    amplitude_fractions: tuple[float, ...] = AMPLITUDE_FRACTIONS
    settle_cycles: int = 3
    quasi_static_frequency: float = 0.1

    def __post_init__(self) -> None:
        object.__setattr__(self, "frequencies", _positive(self.frequencies, "frequencies", "Hz"))
        fractions = _positive(self.amplitude_fractions, "amplitude fractions", "(of the vehicle range)")
        object.__setattr__(self, "amplitude_fractions", fractions)
        _positive((self.quasi_static_frequency,), "quasi-static frequency", "Hz")
        _cycles(self.settle_cycles, "bushing settle cycles")


@dataclass(frozen=True)
class CharacteriseSettings:
    """Both kinds' test settings; the model's kind picks one. `figures`: draw the PNG figures (off: the tables
    alone, for a smoke run whose time matters; each figure costs about 0.3 s of CPU)."""

    damper: DamperTestSettings = field(default_factory=DamperTestSettings)
    bushing: BushingTestSettings = field(default_factory=BushingTestSettings)
    figures: bool = True


# The tests of a smoke run that links a characterisation from its report (`nnfmu demo --quick`): three peak
# velocities (the slowest still reads gas force and friction), the bushing at its full vehicle range at 1 and 10 Hz,
# the quasi-static loop at 0.5 Hz, tables without figures (the road test's three network FMUs took 8 s of CPU with
# figures, 15 of them).
QUICK_SETTINGS = CharacteriseSettings(
    DamperTestSettings(peak_velocities=(0.1, 0.5, 1.0)),
    BushingTestSettings(frequencies=(1.0, 10.0), amplitude_fractions=(1.0,), quasi_static_frequency=0.5),
    figures=False,
)
