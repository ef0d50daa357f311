"""What a component kind is: the one description every floor reads instead of testing element-name prefixes."""

from __future__ import annotations

from dataclasses import dataclass

from nnfmu.errors import NnfmuError


class KindError(NnfmuError, ValueError):
    """An unknown component kind or rig, or a kind that clashes with a registered one; the message names it."""


@dataclass(frozen=True)
class KindChannel:
    """One channel of a kind's vehicle port: the force or torque the component returns for a deflection and its rate
    (suffixes after the element's name, e.g. `bushing_fl_front` + `_axial_force`), each with its SI unit."""

    key: str
    force: str
    force_unit: str
    position: str
    position_unit: str
    rate: str
    rate_unit: str


@dataclass(frozen=True)
class ComponentKind:
    """A component kind: its name, the prefix of its elements' names in a vehicle (`damper_fl`), its channels, the
    rig that records it (`nnfmu rig RIG`) and the rig types that rig offers, an example element, the characterisation
    it gets (`nnfmu characterise`; None: none), the training presets that apply, the vehicle loop's candidate effects
    for it (names in `nnfmu.diagnosis.SYSTEM_EFFECTS`), and whether a lab car measures its own force and stroke
    (in-situ diagnosis)."""

    name: str
    prefix: str
    description: str
    channels: tuple[KindChannel, ...]
    example: str
    rig: str | None = None
    rig_types: tuple[str, ...] = ("passive",)
    characterisation: str | None = None
    presets: tuple[str, ...] = ()
    loop_effects: tuple[str, ...] = ()
    in_situ: bool = False

    def owns(self, name: str) -> bool:
        """Whether an element or port name (`damper_fl`, `damper_fl_force`, `damper`) belongs to this kind."""
        return name == self.prefix or name.startswith(f"{self.prefix}_")

    def element_of_port(self, port: str) -> str | None:
        """The element whose force input `port` is (`bushing_fl_front_axial_force` -> `bushing_fl_front`), or None."""
        for channel in self.channels:
            suffix = f"_{channel.force}"
            if self.owns(port) and port.endswith(suffix) and len(port) > len(suffix):
                return port[: -len(suffix)]
        return None

    def port_channels(self, element: str) -> list[tuple[str, str, str]]:
        """(force input, displacement output, rate output) port names of `element` in the vehicle."""
        return [(f"{element}_{c.force}", f"{element}_{c.position}", f"{element}_{c.rate}") for c in self.channels]
