"""Vehicle models for the virtual road test simulator: linear(ised) state space, exact discretisation, named ports.

Each name loads its module on first use (`nnfmu.faces`), so importing one module of the package (the kernel warm-up
the demo starts before anything else) does not load the others and scipy.
"""

from nnfmu.faces import face

__all__, __getattr__ = face(
    __name__,
    {
        "builtin_elements": ("LinearSpring", "SplineDamper"),
        "errors": ("ParameterError", "VehicleModelError"),
        "full_vehicle": ("build_full_vehicle",),
        "laws": ("BushingTruthLaw", "ComponentLaw", "DamperTruthLaw", "LinearLaw", "linear_laws", "truth_laws"),
        "linear": ("DiscreteVehicle", "LinearVehicle", "SimulationSettings", "simulate"),
        "monolithic": ("MonolithicSettings", "rest_state", "simulate_monolithic"),
        "parameters": ("DEFAULT_FILE", "VehicleParameters"),
        "ports": ("VehiclePort",),
        "quarter_car": ("build_quarter_car",),
        "quarter_car_parameters": ("QuarterCarParameters",),
    },
)
