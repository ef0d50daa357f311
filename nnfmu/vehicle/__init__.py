"""The virtual four-poster's vehicle: parameters, linear and monolithic models, the vehicle FMU, drive synthesis.

Other floors import these names from `nnfmu.vehicle` (tests/test_architecture.py checks it; tests and benchmarks may
reach the modules); each loads its module on first use (`nnfmu.faces`), so a vehicle FMU build does not load the
drive synthesis.
"""

from nnfmu.faces import face

__all__, __getattr__ = face(
    __name__,
    {
        "drive": ("DriveError", "DriveSettings", "KerbStrike", "Pothole", "generate_drive"),
        "dynamics": (
            "BushingTruthLaw",
            "ComponentLaw",
            "DamperTruthLaw",
            "LinearVehicle",
            "MonolithicSettings",
            "rest_state",
            "simulate_monolithic",
            "truth_laws",
        ),
        "dynamics.components": ("STABILISED",),
        "dynamics.full_vehicle": ("FRONT_CORNERS",),
        "dynamics.kernel_warmup": ("kernel_compiled_in_background",),
        "dynamics.ports": ("CORNERS", "actuator_ports"),
        "fmu": ("DEFAULT_SAMPLE_PERIOD", "VehicleBuildSettings", "build_vehicle_fmu", "initial_state", "vehicle_model"),
    },
)
