"""The components' truth physics, shared by the rig simulators (`data/rigs`) and the vehicle's monolithic reference."""

from nnfmu.physics.bushing import IWAN_ELEMENTS, IWAN_SPAN, BushingChannelParams, BushingChannelTruth, BushingParams
from nnfmu.physics.cdc_damper import CDC_CURRENT_RANGE, CDCDamperParams, CDCDamperTruth
from nnfmu.physics.damper import DamperParams, DamperTruth, ValveSide
from nnfmu.physics.effects import (
    BUSHING_EFFECTS,
    CDC_DAMPER_EFFECTS,
    DAMPER_EFFECTS,
    DEFAULT_EFFECTS,
    EFFECTS,
    MR_DAMPER_EFFECTS,
)
from nnfmu.physics.mr_damper import MR_VOLTAGE_RANGE, MRDamperParams, MRDamperTruth
from nnfmu.physics.parameters import describe, param

__all__ = [
    "BUSHING_EFFECTS",
    "BushingChannelParams",
    "BushingChannelTruth",
    "BushingParams",
    "CDC_CURRENT_RANGE",
    "CDC_DAMPER_EFFECTS",
    "CDCDamperParams",
    "CDCDamperTruth",
    "DAMPER_EFFECTS",
    "DEFAULT_EFFECTS",
    "DamperParams",
    "DamperTruth",
    "EFFECTS",
    "IWAN_ELEMENTS",
    "IWAN_SPAN",
    "MR_DAMPER_EFFECTS",
    "MR_VOLTAGE_RANGE",
    "MRDamperParams",
    "MRDamperTruth",
    "ValveSide",
    "describe",
    "param",
]
