"""The physical effects each component's truth law can switch on, and those on by default."""

from __future__ import annotations

DAMPER_EFFECTS = ("hysteresis", "gas_force", "seal_friction", "temperature", "inertia")
BUSHING_EFFECTS = ("viscoelastic", "friction")
EFFECTS: dict[str, tuple[str, ...]] = {"damper": DAMPER_EFFECTS, "bushing": BUSHING_EFFECTS}

# The damper default holds what a velocity-history network can represent; gas force and temperature fade are the
# undeclared effects a later stage must discover.
DEFAULT_EFFECTS: dict[str, tuple[str, ...]] = {
    "damper": ("hysteresis", "seal_friction", "inertia"),
    "bushing": ("viscoelastic", "friction"),
}
