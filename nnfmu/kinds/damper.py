"""The damper kind: one axial channel (force [N] for stroke [m] and its rate), the damper dyno (passive, MR, CDC)."""

from nnfmu.kinds.kind import ComponentKind, KindChannel

DAMPER = ComponentKind(
    name="damper",
    prefix="damper",
    description="a damper along its stroke, rebound (extension) positive; passive or semi-active (MR, CDC)",
    channels=(KindChannel("stroke", "force", "N", "displacement", "m", "velocity", "m/s"),),
    example="damper_fl",
    rig="damper",
    rig_types=("passive", "mr", "cdc"),
    characterisation="damper",
    presets=("damper-spline", "damper-hysteresis", "damper-semiactive"),
    loop_effects=("gas_force",),
    in_situ=True,
)
