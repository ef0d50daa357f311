"""Which component ports are external (forces are inputs), which use the built-in reference element, and which are
external but stabilised by the reference element (see `Assembly.add_force_input`)."""

from __future__ import annotations

from collections.abc import Mapping

from nnfmu.vehicle.dynamics.errors import VehicleModelError

EXTERNAL = "external"
REFERENCE = "reference"
STABILISED = "stabilised"
CHOICES = (EXTERNAL, REFERENCE, STABILISED)


def resolve_components(
    model: str, names: list[str], chosen: Mapping[str, str] | None, default: str = EXTERNAL
) -> dict[str, str]:
    """Every component of `model` mapped to one of `CHOICES`; unnamed components get `default`."""
    chosen = dict(chosen or {})
    unknown = sorted(set(chosen) - set(names))
    if unknown:
        raise VehicleModelError(f"{model}: unknown component(s) {', '.join(unknown)} (has: {', '.join(names)})")
    bad = {k: v for k, v in chosen.items() if v not in CHOICES}
    if bad:
        raise VehicleModelError(f"{model}: component choice(s) {bad}; expected one of {', '.join(CHOICES)}")
    return {name: chosen.get(name, default) for name in names}
