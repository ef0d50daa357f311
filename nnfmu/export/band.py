"""The frequency band a component's training record excited, as its description carries it: read without torch, so
a report on an FMU can say which test points run above it."""

from __future__ import annotations

import math

from nnfmu.component import Component
from nnfmu.export.errors import ExportError

# Metadata key of the band each input's training record excites (what a test above it extrapolates).
TRAINING_BAND = "training_band"


def carried_band(component: Component) -> dict[str, float]:
    """Input name -> upper edge [Hz] of the band its training record excited, as the component carries it (empty
    when it does not: a graph from another tool or an older nnfmu); ExportError naming the value when malformed."""
    carried = component.metadata.get(TRAINING_BAND)
    if carried is None:
        return {}
    edges = carried.get("upper_edge_Hz") if isinstance(carried, dict) else None
    if not isinstance(edges, dict):
        raise ExportError(f"component {component.name!r}: metadata {TRAINING_BAND!r} has no 'upper_edge_Hz' mapping")
    band = {}
    for name, edge in edges.items():
        if isinstance(edge, bool) or not isinstance(edge, (int, float)) or not (math.isfinite(edge) and edge >= 0):
            raise ExportError(
                f"component {component.name!r}: training band of input {name!r} is {edge!r}; it must be a finite "
                "frequency >= 0 Hz"
            )
        band[str(name)] = float(edge)
    return band
