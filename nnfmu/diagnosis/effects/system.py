"""The system half of an effect: how the vehicle loop puts it into the co-simulation. A component's effect is a few
physical terms on its network's output, each at the coefficient its sensitivity is probed with (the loop fits the
coefficients to the vehicle residual); a sensor's is an error of one measured channel (no terms)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

from nnfmu.kinds import KindChannel


@dataclass(frozen=True)
class Term:
    """`coefficient` x the component's port `channel` (None: x 1) added to its output port `output`; `unit` is the
    channel's SI unit."""

    output: str
    channel: str | None
    coefficient: float
    unit: str = ""


class SystemEffect(ABC):
    """An effect the vehicle loop attributes by co-simulated sensitivities: its name, what it is, whether it is a
    measured channel's own error (`on_channel`) rather than a component's, whether its terms are one basis with one
    fitted amplitude (`joint`) scaled by the component's own stiffness per channel (`scaled_by_stiffness`), and why
    an element may offer no terms (`untestable`)."""

    name: ClassVar[str]
    description: ClassVar[str]
    on_channel: ClassVar[bool] = False
    joint: ClassVar[bool] = False
    scaled_by_stiffness: ClassVar[bool] = False
    untestable: ClassVar[str] = ""

    @abstractmethod
    def terms(self, channels: Sequence[KindChannel], stiffness: Mapping[str, float]) -> tuple[Term, ...]:
        """The terms on a component of these kind `channels` (its network's own `stiffness` per output, N/m or
        N.m/rad, where `scaled_by_stiffness`); empty for a channel's error or where nothing can be probed."""
