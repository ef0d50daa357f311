"""Rig simulators that make realistic "measured" data from known physics, with the truth written beside it."""

from nnfmu.data.rigs.bushing_rig import CHANNELS as BUSHING_CHANNELS
from nnfmu.data.rigs.bushing_rig import BushingRig
from nnfmu.data.rigs.command import CommandSchedule
from nnfmu.data.rigs.damper_rig import DamperDyno
from nnfmu.data.rigs.excitation import Motion, SineLevel, SpectrumShape
from nnfmu.data.rigs.options import DAMPER_TYPES, EXCITATIONS, KINDS, RigOptions
from nnfmu.data.rigs.semiactive_rig import COMMAND_CHANNELS
from nnfmu.data.rigs.simulate import RigRun, simulate_rig, write_rig
from nnfmu.data.rigs.truth import truth_path
from nnfmu.data.rigs.vehicle_drive import (
    RIG_BANDS,
    DriveDesign,
    VehicleDrive,
    design_damper_drive,
    design_vehicle_drive,
)
from nnfmu.data.rigs.vehicle_dyno import simulate_vehicle_damper_dyno, write_vehicle_damper_dyno
from nnfmu.data.rigs.vehicle_rig import simulate_vehicle_rig, write_vehicle_rig
from nnfmu.physics import (
    BUSHING_EFFECTS,
    DAMPER_EFFECTS,
    DEFAULT_EFFECTS,
    BushingChannelParams,
    BushingChannelTruth,
    BushingParams,
    DamperParams,
    DamperTruth,
    ValveSide,
)

__all__ = [
    "BUSHING_CHANNELS",
    "BUSHING_EFFECTS",
    "BushingChannelParams",
    "BushingChannelTruth",
    "BushingParams",
    "BushingRig",
    "COMMAND_CHANNELS",
    "CommandSchedule",
    "DAMPER_TYPES",
    "DAMPER_EFFECTS",
    "DEFAULT_EFFECTS",
    "DamperDyno",
    "DamperParams",
    "DamperTruth",
    "DriveDesign",
    "EXCITATIONS",
    "KINDS",
    "Motion",
    "RIG_BANDS",
    "RigOptions",
    "RigRun",
    "SineLevel",
    "SpectrumShape",
    "ValveSide",
    "VehicleDrive",
    "design_damper_drive",
    "design_vehicle_drive",
    "simulate_rig",
    "simulate_vehicle_damper_dyno",
    "simulate_vehicle_rig",
    "truth_path",
    "write_rig",
    "write_vehicle_damper_dyno",
    "write_vehicle_rig",
]
