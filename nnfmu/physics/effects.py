"""The physical effects each component's truth law can switch on, and those on by default."""

from __future__ import annotations

# "presliding" (off by default) turns the seal friction into a Jenkins element: the seal sticks with a pre-sliding
# stiffness up to its break-away force, then slides.
DAMPER_EFFECTS = ("hysteresis", "gas_force", "seal_friction", "temperature", "inertia", "presliding")
BUSHING_EFFECTS = ("viscoelastic", "friction")
MR_DAMPER_EFFECTS = ("command_lag", "gas_force", "inertia")
CDC_DAMPER_EFFECTS = ("valve_lag", "gas_force", "seal_friction", "inertia")
EFFECTS: dict[str, tuple[str, ...]] = {
    "damper": DAMPER_EFFECTS,
    "bushing": BUSHING_EFFECTS,
    "mr_damper": MR_DAMPER_EFFECTS,
    "cdc_damper": CDC_DAMPER_EFFECTS,
}

# The damper default holds what a velocity-history network can represent; gas force and temperature fade are the
# undeclared effects a later stage must discover. The semi-active dampers' networks see the displacement, so their
# accumulator's gas force is on by default.
DEFAULT_EFFECTS: dict[str, tuple[str, ...]] = {
    "damper": ("hysteresis", "seal_friction", "inertia"),
    "bushing": ("viscoelastic", "friction"),
    "mr_damper": MR_DAMPER_EFFECTS,
    "cdc_damper": CDC_DAMPER_EFFECTS,
}
