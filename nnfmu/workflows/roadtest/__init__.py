"""Virtual road test simulator runs: quarter car and full vehicle with network FMUs vs the monolithic reference.

Each name loads its module on first use (`nnfmu.faces`): `nnfmu cosim` reads the training envelope through
`roadtest.envelope`, and importing this package must not import the training side (torch) with it.
"""

from nnfmu.faces import face

__all__, __getattr__ = face(
    __name__,
    {
        "bushing_drive": ("BushingDriveSettings", "VehicleBushingModels", "train_vehicle_bushings"),
        "damper_drive": ("VehicleDamperModels", "train_vehicle_dampers"),
        "envelope": ("Excursion", "excursion"),
        "open_loop": ("network_errors", "open_loop_replay"),
        "runs": ("RoadTestResult", "RoadTestSettings", "SystemResult", "SystemRun", "run_road_test", "system_folder"),
        "systems": (
            "BUSHING_MODELS",
            "DAMPER_MODELS",
            "SYSTEMS",
            "ComponentFmus",
            "RoadTestError",
            "build_component_fmus",
            "build_vehicle",
            "bushing_onnx",
            "write_system",
        ),
        "thesis": ("ThesisRow", "amplitude_ratio", "thesis_row"),
        "truth_reference": ("Reference", "actuator_inputs", "monolithic_reference"),
    },
)
