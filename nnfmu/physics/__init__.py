"""The components' truth physics, shared by the rig simulators (`data/rigs`) and the vehicle's monolithic reference."""

from .bushing import IWAN_ELEMENTS, IWAN_SPAN, BushingChannelParams, BushingChannelTruth, BushingParams
from .damper import DamperParams, DamperTruth, ValveSide
from .effects import BUSHING_EFFECTS, DAMPER_EFFECTS, DEFAULT_EFFECTS, EFFECTS
from .parameters import describe, param

__all__ = [
    "BUSHING_EFFECTS",
    "BushingChannelParams",
    "BushingChannelTruth",
    "BushingParams",
    "DAMPER_EFFECTS",
    "DEFAULT_EFFECTS",
    "DamperParams",
    "DamperTruth",
    "EFFECTS",
    "IWAN_ELEMENTS",
    "IWAN_SPAN",
    "ValveSide",
    "describe",
    "param",
]
