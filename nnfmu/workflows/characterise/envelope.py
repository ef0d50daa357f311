"""Is a test point inside the network's training envelope? A network answers outside the positions and rates its
rig data held by extrapolation, so the report says per test point which driven input leaves its port's range."""

from __future__ import annotations

import math
from collections.abc import Mapping

from nnfmu.component import Component

INSIDE = "inside"


def envelope_note(component: Component, peaks: Mapping[str, float]) -> str:
    """`INSIDE` when every driven input's peak ±value (input name -> peak magnitude in its port's unit) lies within
    the port's training envelope (or the port has none), else `outside: <input> ±<peak> beyond [min, max] <unit>`."""
    ports = {p.name: p for p in component.inputs}
    beyond = []
    for name, peak in peaks.items():
        port = ports.get(name)
        if port is None or (port.in_envelope(peak) and port.in_envelope(-peak)):
            continue
        lo = -math.inf if port.min is None else port.min
        hi = math.inf if port.max is None else port.max
        beyond.append(f"{name} ±{peak:.3g} beyond [{lo:.3g}, {hi:.3g}] {port.unit}".rstrip())
    return INSIDE if not beyond else "outside: " + "; ".join(beyond)
