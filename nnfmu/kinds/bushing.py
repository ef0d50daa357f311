"""The bushing kind: four channels (axial and radial force, axial and conical torque), the four-channel rig."""

from nnfmu.kinds.kind import ComponentKind, KindChannel

BUSHING = ComponentKind(
    name="bushing",
    prefix="bushing",
    description="a rubber bushing between an arm's inner sleeve and the body's outer sleeve",
    channels=(
        KindChannel("axial", "axial_force", "N", "axial_displacement", "m", "axial_velocity", "m/s"),
        KindChannel("radial", "radial_force", "N", "radial_displacement", "m", "radial_velocity", "m/s"),
        KindChannel(
            "axial_rotation", "axial_torque", "N.m", "axial_rotation", "rad", "axial_angular_velocity", "rad/s"
        ),
        KindChannel(
            "conical_rotation", "conical_torque", "N.m", "conical_rotation", "rad", "conical_angular_velocity", "rad/s"
        ),
    ),
    example="bushing_fl_front",
    rig="bushing",
    characterisation="bushing",
    presets=("bushing-axial-force", "bushing-radial-force", "bushing-axial-torque", "bushing-conical-torque"),
    loop_effects=("stiffness",),
)
