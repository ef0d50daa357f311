"""Is a bushing network passive? The energy each channel absorbs over small sine cycles inside its training envelope.

A real bushing absorbs energy over every closed cycle (its loss angle is positive). A network can learn the opposite
where its record taught it little, e.g. loops of a few micrometres run backwards by its stop operators: it then gives
energy back. Coupled to the vehicle's stiff LCA modes (150-250 Hz) such a channel is a negative damper: its motion
grows by itself until the network turns dissipative at larger amplitude, and stays an irregular, chaotic oscillation
whose history depends on the input's last bit (docs/passivity.md).

`active_cycles` drives each channel of a step graph alone with x = x0 + A sin(2 pi f t), v = dx/dt at its sample
period (the other inputs 0), about the middle x0 of its position envelope (a bushing's working point: a vehicle-derived
record is deflected under the car's weight), for amplitudes A fractions of the envelope's half-width and frequencies
from the rig's band up to the vehicle's arm modes, whenever the rate amplitude stays inside the rate envelope, and
returns those cycles in which the channel gives energy back. Above the rig's band (a drive to 40 Hz) a network is
fitted to nothing, so its loss angle there is whatever its features extrapolate: the road test's axial force network
with a 1 ms high-pass in its memory absorbed energy at 10 Hz and gave it back at 200 Hz, where the full vehicle then
oscillated when exchanged every 0.1 ms. Torch-free: onnxruntime through `run_step_graph`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import onnx

from nnfmu.component import Component
from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.export.step_runner import run_step_graph

ENVELOPE_FRACTIONS = (0.01, 0.02, 0.05, 0.1, 0.2)  # sine amplitudes, as fractions of the envelope's half-width
# [Hz] inside the rig's band, and the front LCA's stiff modes (150-250 Hz) a network only extrapolates to; those above
# a quarter of the sample rate are left out (too few samples per cycle)
FREQUENCIES = (10.0, 100.0, 200.0)
SETTLE = 0.3  # [s] run before the measured cycles (the networks' memory: high-passes up to 0.1 s)
MEASURED = 0.2  # [s] of whole cycles over which the energy is summed
STATELESS_PERIOD = 1e-3  # [s] the samples a stateless graph is evaluated at (the master's default step)
MAX_SAMPLES = 20_000  # a graph sampled faster than (SETTLE + MEASURED) / this is not checked (bounded work)
ACTIVE_SINE = -0.01  # sin(loss angle) below this (-0.57 deg): the channel gives energy back, beyond rounding


@dataclass(frozen=True)
class Cycle:
    """One sine test of one channel: amplitude [position unit], frequency [Hz], energy absorbed per cycle [J] and
    the sine of the loss angle it implies (negative: energy given back)."""

    channel: str
    amplitude: float
    frequency: float
    energy: float
    loss_sine: float

    def describe(self, unit: str) -> str:
        """One line: channel, amplitude, frequency and the energy returned per cycle."""
        return (
            f"{self.channel}: {self.amplitude:.3g} {unit} at {self.frequency:g} Hz gives back {-self.energy:.3g} J per "
            f"cycle (loss angle {np.degrees(np.arcsin(max(self.loss_sine, -1.0))):.1f} deg)"
        )


def cycle_energy(
    graph: onnx.ModelProto,
    position: str,
    rate: str,
    force: str,
    amplitude: float,
    frequency: float,
    centre: float = 0.0,
) -> Cycle:
    """Energy [J] `graph`'s output `force` absorbs per cycle of a sine about `centre` on `position` (`rate` its
    derivative), the other inputs 0, at its sample period, summed over MEASURED s of whole cycles after SETTLE s
    (trapezoids of force over the sampled motion)."""
    component = Component.from_onnx(graph)
    period = component.sample_period or STATELESS_PERIOD
    n = round((SETTLE + MEASURED) / period) + 1
    t = np.arange(n) * period
    x = centre + amplitude * np.sin(2.0 * np.pi * frequency * t)
    inputs = {port.name: np.zeros(n) for port in component.inputs}
    inputs[position] = x
    inputs[rate] = amplitude * 2.0 * np.pi * frequency * np.cos(2.0 * np.pi * frequency * t)
    f = run_step_graph(graph, inputs)[force]
    kept = t >= SETTLE - 0.5 * period
    xs, fs = x[kept], f[kept]
    cycles = MEASURED * frequency
    energy = float(np.sum(0.5 * (fs[1:] + fs[:-1]) * np.diff(xs)) / cycles)
    first = 2.0 * abs(np.mean((fs[:-1] - fs.mean()) * np.exp(-2j * np.pi * frequency * t[kept][:-1])))  # 1st harmonic
    scale = np.pi * amplitude * first
    return Cycle(force, amplitude, frequency, energy, energy / scale if scale > 0 else 0.0)


def active_cycles(graph: onnx.ModelProto, frequencies: Sequence[float] = FREQUENCIES) -> list[Cycle]:
    """The sine tests (about the middle of each bushing channel's position envelope, `ENVELOPE_FRACTIONS` of its
    half-width x `frequencies`) in which `graph` gives energy back, over every bushing channel it computes from a
    position and rate with an envelope (a stateless graph evaluated every STATELESS_PERIOD; none checked where that
    needs over MAX_SAMPLES samples)."""
    component = Component.from_onnx(graph)
    period = component.sample_period or STATELESS_PERIOD
    if (SETTLE + MEASURED) / period > MAX_SAMPLES:
        return []
    ports = {port.name: port for port in component.inputs}
    outputs = {port.name for port in component.outputs}
    found = []
    for channel in BUSHING_CHANNELS.values():
        position, rate = ports.get(channel.position), ports.get(channel.rate)
        if position is None or rate is None or channel.force not in outputs:
            continue
        if None in (position.min, position.max, rate.min, rate.max):
            continue
        centre, half_width = 0.5 * (position.min + position.max), 0.5 * (position.max - position.min)
        rate_reach = min(abs(rate.min), abs(rate.max))
        for fraction in ENVELOPE_FRACTIONS:
            for frequency in frequencies:
                amplitude = fraction * half_width
                if amplitude * 2.0 * np.pi * frequency > rate_reach or frequency * period > 0.25:
                    continue  # extrapolation (the envelope check's business), or too few samples per cycle
                cycle = cycle_energy(graph, channel.position, channel.rate, channel.force, amplitude, frequency, centre)
                if cycle.loss_sine < ACTIVE_SINE:
                    found.append(cycle)
    return found


def passivity_warnings(name: str, graph: onnx.ModelProto) -> list[str]:
    """One warning line (no 'warning:' prefix) per channel of `graph` (network `name`) that gives energy back in a
    sine test (its worst test), saying what it means in the closed loop."""
    units = {port.name: port.unit for port in Component.from_onnx(graph).inputs}
    worst: dict[str, Cycle] = {}
    for cycle in active_cycles(graph):
        if cycle.channel not in worst or cycle.loss_sine < worst[cycle.channel].loss_sine:
            worst[cycle.channel] = cycle
    positions = {c.force: c.position for c in BUSHING_CHANNELS.values()}
    return [
        f"{name}: not passive: {cycle.describe(units[positions[channel]])}; coupled to the vehicle this "
        "channel can oscillate by itself and its loads depend on the input's last bit (docs/passivity.md)"
        for channel, cycle in worst.items()
    ]
