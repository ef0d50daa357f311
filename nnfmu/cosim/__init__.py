"""The co-simulation master: SSP systems of FMUs stepped on fmpy, driven through a `DriveBinding`.

Other floors import these names from `nnfmu.cosim` (tests/test_architecture.py checks it; tests and benchmarks may
reach the modules); each loads its module on first use (`nnfmu.faces`).
"""

from nnfmu.faces import face

__all__, __getattr__ = face(
    __name__,
    {
        "binding": ("DriveBinding", "bind_free_inputs", "free_inputs"),
        "container.build": ("build_system_fmu",),
        "container.engine": ("check_compiled", "cosimulate_compiled"),
        "container.plan": ("SystemPlan",),
        "drive_inputs": ("DriveInputError",),
        "instances": ("InstancePool",),
        "libcosim_runner": ("run_libcosim",),
        "master": ("CosimWarning", "Progress", "cosimulate"),
        "replay": ("replay_fmu",),
        "results": ("CosimResult", "save_result"),
        "settings": ("DEFAULT_STEP", "CosimError", "CosimSettings"),
        "slave": ("FmuSlave",),
        "ssp": (
            "SSD_NAME",
            "Connection",
            "Connector",
            "Element",
            "SspError",
            "SystemStructure",
            "check_against_fmus",
            "connect_by_name",
            "local_fmu",
            "open_system",
            "write_ssd",
        ),
        "step_study": ("DEFAULT_TARGET", "StepStudy", "study_lines", "study_step"),
    },
)
