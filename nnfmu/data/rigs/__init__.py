"""Rig simulators that make realistic "measured" data from known physics, with the truth written beside it."""

from .bushing import BushingChannelParams, BushingChannelTruth, BushingParams
from .bushing_rig import CHANNELS as BUSHING_CHANNELS
from .bushing_rig import BushingRig
from .damper import DamperParams, DamperTruth, ValveSide
from .damper_rig import DamperDyno
from .excitation import Motion, SineLevel, SpectrumShape
from .options import BUSHING_EFFECTS, DAMPER_EFFECTS, DEFAULT_EFFECTS, EXCITATIONS, KINDS, RigOptions
from .run import RigRun, simulate_rig, write_rig
from .truth import truth_path

__all__ = [
    "BUSHING_CHANNELS",
    "BUSHING_EFFECTS",
    "BushingChannelParams",
    "BushingChannelTruth",
    "BushingParams",
    "BushingRig",
    "DAMPER_EFFECTS",
    "DEFAULT_EFFECTS",
    "DamperDyno",
    "DamperParams",
    "DamperTruth",
    "EXCITATIONS",
    "KINDS",
    "Motion",
    "RigOptions",
    "RigRun",
    "SineLevel",
    "SpectrumShape",
    "ValveSide",
    "simulate_rig",
    "truth_path",
    "write_rig",
]
