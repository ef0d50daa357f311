"""A rubber component's stiffness changed (aged or another compound): every channel stiffer or softer alike.

A system effect only: on the rig the network learnt the stiffness its record shows (its deflection is the network's
own input), so the component diagnosis has nothing to add; in the car the rubber may differ from the rig's sample."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from nnfmu.diagnosis.effects.system import SystemEffect, Term
from nnfmu.kinds import KindChannel


class Stiffness(SystemEffect):
    """The element's own stiffness per channel times that channel's deflection or rotation on its own output, all
    channels one basis: the fitted amplitude is the fraction of stiffness added."""

    name = "stiffness"
    description = "stiffness of every channel changed alike (aged rubber)"
    joint = True
    scaled_by_stiffness = True
    untestable = "no deflection and force of the element in the replay to scale by"

    def terms(self, channels: Sequence[KindChannel], stiffness: Mapping[str, float]) -> tuple[Term, ...]:
        """Per channel with a known stiffness, that stiffness times its deflection or rotation on its output."""
        return tuple(
            Term(c.force, c.position, stiffness[c.force], c.position_unit) for c in channels if c.force in stiffness
        )
