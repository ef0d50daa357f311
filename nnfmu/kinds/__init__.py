"""The registry of component kinds: each kind one module (`damper.py`, `bushing.py`) and one line in `KINDS`.

Every floor asks the registry what an element is (`kind_of("damper_fl")`), which channels a component has, which rig
records it; a floor that calls a function of its own per kind keeps a small table keyed by the kind's name."""

from __future__ import annotations

from nnfmu.kinds.bushing import BUSHING
from nnfmu.kinds.damper import DAMPER
from nnfmu.kinds.kind import ComponentKind, KindChannel, KindError

# The registry, in order; a new kind: its module and one entry here.
KINDS: dict[str, ComponentKind] = {k.name: k for k in (DAMPER, BUSHING)}

__all__ = [
    "BUSHING",
    "DAMPER",
    "KINDS",
    "ComponentKind",
    "KindChannel",
    "KindError",
    "element_of_port",
    "get_kind",
    "kind_of",
    "kind_of_rig",
]


def kind_of(name: str) -> ComponentKind | None:
    """The kind whose elements' names `name` (an element or one of its ports) starts with; None for no kind."""
    return next((k for k in KINDS.values() if k.owns(name)), None)


def get_kind(name: str) -> ComponentKind:
    """The registered kind called `name`; KindError naming the registered ones otherwise."""
    if name not in KINDS:
        raise KindError(f"unknown component kind {name!r}; registered kinds: {', '.join(KINDS)}")
    return KINDS[name]


def kind_of_rig(rig: str) -> ComponentKind:
    """The kind the rig `rig` records (`nnfmu rig RIG`); KindError naming the rigs otherwise."""
    found = next((k for k in KINDS.values() if k.rig == rig), None)
    if found is None:
        rigs = ", ".join(k.rig for k in KINDS.values() if k.rig)
        raise KindError(f"unknown rig kind {rig!r}; valid kinds: {rigs}")
    return found


def element_of_port(port: str) -> str | None:
    """The component element whose force input `port` is (`damper_fl_force` -> `damper_fl`); None for no kind's."""
    kind = kind_of(port)
    return kind.element_of_port(port) if kind is not None else None
