"""Build a native FMU: generated C for the graph + the fixed FMI glue from `templates/`, compiled for each platform.

FMU layout: `modelDescription.xml`, `binaries/<platform>/<identifier>.so|.dll` (this machine's, and win64 when the
MinGW-w64 cross compiler is installed or asked for), `sources/` (glue, config.h, graph.c/.h, FMI headers copied from
the installed fmpy, buildDescription.xml) and, when the graph carries a reference stimulus, reference results under
`extra/org.fmi-standard.fmi-ls-ref/`. Nothing of Python, onnxruntime or torch is needed to run it.
"""

from __future__ import annotations

import shutil
import tempfile
import warnings
from pathlib import Path

import onnx

from nnfmu.fmu.errors import FmuBuildError, PlatformSkippedWarning
from nnfmu.fmu.model_description import (
    FmuIdentity,
    ModelDescriptionView,
    instantiation_token,
    render_build_description,
    render_model_description,
    tensor_dependencies,
)
from nnfmu.fmu.names import c_identifier
from nnfmu.fmu.native.codegen import UnsupportedGraphError, generate_c
from nnfmu.fmu.native.compiler import compile_shared_library, select_targets
from nnfmu.fmu.native.config import GraphLayout, port_map, render_config
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.package import package_fmu
from nnfmu.fmu.reference_results import write_reference_results
from nnfmu.fmu.variables import fmu_variables
from nnfmu.resources import templates_dir

GLUE_HEADERS = ("nn_fmu.h",)
FMI_HEADERS = {
    2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
    3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h"),
}


def source_files(fmi_version: int) -> list[str]:
    """The C files compiled into an FMU of `fmi_version` (as listed in buildDescription.xml)."""
    return ["nn_fmu.c", "graph.c", f"fmi{fmi_version}Functions.c"]


def fmi_headers_dir() -> Path:
    """The FMI standard headers shipped with the installed fmpy (`fmpy/c-code`)."""
    import fmpy

    folder = Path(fmpy.__file__).resolve().parent / "c-code"
    if not (folder / "fmi2Functions.h").is_file():
        raise FmuBuildError(f"FMI headers not found in {folder}; reinstall fmpy")
    return folder


def load_model(onnx_path: Path) -> onnx.ModelProto:
    """Read an ONNX file, naming it in the error if it cannot be read."""
    try:
        return onnx.load(str(onnx_path))
    except Exception as err:  # onnx raises DecodeError, OSError or its own errors
        raise FmuBuildError(f"{onnx_path}: cannot read the ONNX model: {err}") from err


def default_output(identifier: str) -> Path:
    """Where `nnfmu build` writes an FMU when `--out` is not given."""
    return Path("exported") / f"{identifier}.fmu"


def build_native(onnx_path: Path, options: BuildOptions) -> Path:
    """Build the native FMU for the step graph `onnx_path`; return its path. Raises FmuBuildError."""
    onnx_path = Path(onnx_path)
    model = load_model(onnx_path)
    component = options.component_of(model, onnx_path)
    identifier = c_identifier(component.name)
    target = Path(options.out) if options.out is not None else default_output(identifier)
    try:
        generated = generate_c(model, prefix="nn")
    except UnsupportedGraphError as err:
        raise FmuBuildError(f"{onnx_path}: {err}") from err
    variables = fmu_variables(component)
    layout = GraphLayout.of(model, generated.input_sizes, generated.output_sizes)
    ports = port_map(component, layout)
    fmi = options.fmi_version
    identity = FmuIdentity(component.name, identifier, instantiation_token(onnx_path.read_bytes(), component, fmi), fmi)
    view = ModelDescriptionView(identity, component, variables, tensor_dependencies(model), source_files(fmi))
    platforms, skipped = select_targets(options.platforms)
    if skipped:
        warnings.warn(skipped, PlatformSkippedWarning, stacklevel=2)

    with tempfile.TemporaryDirectory(prefix="nnfmu-build-") as tmp:
        tree = Path(tmp) / "fmu"
        sources = tree / "sources"
        sources.mkdir(parents=True)
        glue = templates_dir() / "c"
        for name in (*GLUE_HEADERS, "nn_fmu.c", f"fmi{fmi}Functions.c"):
            shutil.copyfile(glue / name, sources / name)
        for name in FMI_HEADERS[fmi]:
            shutil.copyfile(fmi_headers_dir() / name, sources / name)
        (sources / "config.h").write_text(render_config(component, variables, ports, identity, onnx_path.name),
                                          encoding="utf-8")
        (sources / "graph.h").write_text(generated.header, encoding="utf-8")
        (sources / "graph.c").write_text(generated.source, encoding="utf-8")
        (sources / "buildDescription.xml").write_text(render_build_description(identifier, source_files(fmi)),
                                                      encoding="utf-8")
        (tree / "modelDescription.xml").write_text(render_model_description(view), encoding="utf-8")
        write_reference_results(tree, model, component, variables)
        for platform in platforms:
            binary = tree / "binaries" / platform.folder(fmi) / f"{identifier}{platform.suffix}"
            compile_shared_library(platform, [sources / s for s in source_files(fmi)], sources, binary)
        return package_fmu(tree, target)
