"""Is a test point inside the network's training envelope? A network answers outside the positions and rates its
rig data held, and above the frequency band its record excited, by extrapolation, so the report says per test point
which driven input leaves its port's range and whether the test's frequency lies above the inputs' band."""

from __future__ import annotations

import math
from collections.abc import Mapping

from nnfmu.component import Component
from nnfmu.export.band import carried_band

INSIDE = "inside"


def envelope_note(component: Component, peaks: Mapping[str, float], frequency: float | None = None) -> str:
    """`INSIDE` when every driven input's peak ±value (input name -> peak magnitude in its port's unit) lies within
    the port's training envelope (or the port has none) and the test's `frequency` [Hz] is at most the band the driven
    inputs' training record excited (when the component carries it), else `outside: <input> ±<peak> beyond [min, max]
    <unit>` and/or `outside: <f> Hz above the training band (<edge> Hz, <input>)`."""
    ports = {p.name: p for p in component.inputs}
    beyond = []
    for name, peak in peaks.items():
        port = ports.get(name)
        if port is None or (port.in_envelope(peak) and port.in_envelope(-peak)):
            continue
        lo = -math.inf if port.min is None else port.min
        hi = math.inf if port.max is None else port.max
        beyond.append(f"{name} ±{peak:.3g} beyond [{lo:.3g}, {hi:.3g}] {port.unit}".rstrip())
    above = _above_band(component, peaks, frequency)
    if above:
        beyond.append(above)
    return INSIDE if not beyond else "outside: " + "; ".join(beyond)


def _above_band(component: Component, peaks: Mapping[str, float], frequency: float | None) -> str:
    """The note for a test above the widest band of the driven inputs' training record; empty when it is not above,
    or when the component carries no band for them."""
    band = carried_band(component)  # ExportError naming the value when a graph from elsewhere carries it malformed
    edges = {name: band[name] for name in peaks if name in band}
    if frequency is None or not edges:
        return ""
    widest = max(edges, key=lambda name: edges[name])
    if frequency <= edges[widest]:
        return ""
    return f"{frequency:.3g} Hz above the training band ({edges[widest]:.3g} Hz, {widest})"
