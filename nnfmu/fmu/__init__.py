"""ONNX step graph to FMI co-simulation FMU: the native C backend (default) and the pythonfmu fallback.

Other floors import these names from `nnfmu.fmu` (tests/test_architecture.py checks it; tests and benchmarks may
reach the modules); each loads its module on first use (`nnfmu.faces`). Nothing here imports torch.
"""

from nnfmu.faces import face

__all__, __getattr__ = face(
    __name__,
    {
        "build": ("build_fmu", "build_fmu_from_model"),
        "check": ("check_fmu", "report_lines"),
        "errors": ("CompilerError", "FmuBuildError", "PlatformSkippedWarning"),
        "factory": ("load_onnx",),
        "model_description": ("GENERATION_TOOL", "SI_EXPONENTS", "render_build_description"),
        "names": ("c_identifier",),
        "native.backend": ("fmi_headers_dir",),
        "native.compiler": ("compile_shared_library",),
        "native.toolchain": (
            "PLATFORMS",
            "Platform",
            "Target",
            "host_binaries_only",
            "host_platform_of",
            "host_target",
            "select_targets",
        ),
        "options": ("BACKENDS", "FMI_VERSIONS", "Backend", "BuildOptions", "FmiVersion"),
        "package": ("binary_folders", "package_fmu"),
        "reference_results": ("has_reference_results",),
        "sampling": ("fmu_sample_period", "read_sample_period"),
        "step_graph": (
            "GRAPH_MEMBER",
            "StepGraphError",
            "StepGraphRecord",
            "check_same_graph",
            "extract_fmu_graph",
            "load_fmu_graph",
            "read_fmu_graph",
        ),
    },
)
