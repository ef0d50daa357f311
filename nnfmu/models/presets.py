"""Presets: the thesis's component networks and nnfmu's default for each, with the default output channel and
training settings, so `nnfmu train DATA --preset NAME` needs nothing else.

Each preset holds two definitions. `thesis_spec`/`thesis` reproduce the thesis (inputs, delays, fixed hidden size;
`--thesis`). `spec`/`architecture` are what nnfmu trains by default, with hidden sizes chosen by validation error
starting at the thesis's size. Bushings: the same input channels plus a bank of first-order low-pass filters of the
position with one time constant per decade (1, 10, 100 ms) — the memory of a generalised Maxwell (Prony-series)
material, which a one-sample delay line at 1 kHz cannot hold. Damper hysteresis: velocity on an octave-spaced
delay line (0, 2, 4, 8, 16 samples) instead of the thesis's single delay.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from nnfmu.models.features import FeatureSpec, Lowpass, Tap
from nnfmu.models.train import Architecture, TrainSettings

# Hidden sizes tried by default after the thesis's size (chosen by validation error).
AUTO_HIDDEN = (3, 5, 7, 9, 12)
# GRU hidden size for the recurrent option when the user gives none.
GRU_HIDDEN = (8,)
# Time constants [s] of the default low-pass memory bank: one per decade across the rigs' 1-20 Hz band and beyond.
MEMORY_TAUS = (0.001, 0.01, 0.1)
# Default damper-hysteresis delays [samples]: the thesis's time-delay idea with octave-spaced delays, so that at
# 1 kHz the line spans the valve's lag (~1-4 ms) and the acceleration (inertia) over 16 ms.
HYSTERESIS_DELAYS = (0, 2, 4, 8, 16)


@dataclass(frozen=True)
class Preset:
    """A named component model: the thesis's definition and nnfmu's default (feature spec with the default output
    channel, network), plus training defaults."""

    name: str
    description: str
    thesis_spec: FeatureSpec
    thesis: Architecture
    spec: FeatureSpec
    architecture: Architecture
    settings: TrainSettings = TrainSettings()

    @property
    def output(self) -> str:
        return self.spec.output


def auto_from(thesis_hidden: int) -> tuple[int, ...]:
    """Hidden sizes tried by default: the thesis's size and the larger AUTO_HIDDEN sizes."""
    return (thesis_hidden, *(h for h in AUTO_HIDDEN if h > thesis_hidden))


def _taps(channels: tuple[str, ...], delays: tuple[int, ...]) -> tuple[Tap, ...]:
    return tuple(Tap(c, delays) for c in channels)


def _preset(
    name: str, description: str, channels: tuple[str, ...], output: str, thesis_delays: tuple[int, ...], hidden: int,
    memory_of: str | None, delays: tuple[int, ...] = (0,),
) -> Preset:
    """A preset whose thesis net taps `channels` at `thesis_delays` with `hidden` units; the default taps them at
    `delays`, adds the low-pass memory bank of `memory_of` (None: no bank) and searches the hidden size."""
    derived = tuple(Lowpass(memory_of, tau=t) for t in MEMORY_TAUS) if memory_of else ()
    return Preset(
        name=name,
        description=description,
        thesis_spec=FeatureSpec(taps=_taps(channels, thesis_delays), output=output),
        thesis=Architecture("mlp", (hidden,)),
        spec=FeatureSpec(taps=_taps(channels, delays), output=output, derived=derived),
        architecture=Architecture("mlp", auto_from(hidden)),
    )


PRESETS: dict[str, Preset] = {
    p.name: p
    for p in (
        _preset(
            "damper-spline", "damper force-velocity characteristic (thesis 1-3-1 on velocity)",
            ("velocity",), "force", (0,), 3, None,
        ),
        _preset(
            "damper-hysteresis", "damper force with hysteresis and inertia from velocity history (thesis 2-5-1 time-delay net)",
            ("velocity",), "force", (0, 1), 5, None, HYSTERESIS_DELAYS,
        ),
        _preset(
            "bushing-axial-force", "bushing axial force from axial displacement and velocity (thesis 2-3-1)",
            ("axial_displacement", "axial_velocity"), "axial_force", (0,), 3, "axial_displacement",
        ),
        _preset(
            "bushing-radial-force", "bushing radial force from radial displacement and velocity (thesis 2-3-1)",
            ("radial_displacement", "radial_velocity"), "radial_force", (0,), 3, "radial_displacement",
        ),
        _preset(
            "bushing-axial-torque", "bushing axial torque from rotation and angular velocity (thesis 4-7-1 with delays)",
            ("axial_rotation", "axial_angular_velocity"), "axial_torque", (0, 1), 7, "axial_rotation",
        ),
        _preset(
            "bushing-conical-torque", "bushing conical torque from conical rotation and rate (thesis 4-7-1 with delays)",
            ("conical_rotation", "conical_angular_velocity"), "conical_torque", (0, 1), 7, "conical_rotation",
        ),
    )
}


def get_preset(name: str) -> Preset:
    """The preset called `name`; ValueError listing the known names otherwise."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown preset {name!r}; known presets: {', '.join(PRESETS)}") from None


def custom_spec(
    base: FeatureSpec, output: str | None = None, inputs: tuple[str, ...] = (), delays: tuple[int, ...] = ()
) -> FeatureSpec:
    """`base` with the output channel and/or the input taps replaced; `delays` apply to every input channel.

    Delays without inputs re-tap the base's own input channels; inputs without delays use delay 0 only. Custom
    inputs drop the base's derived features (they belong to its channels).
    """
    spec = base
    if inputs or delays:
        channels = tuple(inputs) if inputs else tuple(t.channel for t in spec.taps)
        derived = () if inputs else spec.derived
        spec = FeatureSpec(taps=_taps(channels, tuple(delays) or (0,)), output=spec.output, derived=derived)
    if output:
        spec = FeatureSpec(taps=spec.taps, output=output, derived=spec.derived)
    return spec


def recurrent(architecture: Architecture, hidden: tuple[int, ...] = ()) -> Architecture:
    """The GRU version of an architecture (hidden sizes given, or GRU_HIDDEN)."""
    return replace(architecture, kind="gru", hidden=tuple(hidden) or GRU_HIDDEN)
