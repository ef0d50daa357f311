"""The native backend of the FMU factory: generated C for the graph + the fixed FMI glue from `templates/`, compiled.

FMU layout: `modelDescription.xml`, `binaries/<platform>/<identifier>.so|.dll|.dylib` (every platform a compiler
here builds, or those asked for: `toolchain.py`), `sources/` (glue, config.h, graph.c/.h, FMI headers copied from
the installed fmpy, buildDescription.xml) and, when the graph carries a reference stimulus, reference results under
`extra/org.fmi-standard.fmi-ls-ref/`. Nothing of Python, onnxruntime or torch is needed to run it.
"""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

from nnfmu.fmu.errors import FmuBuildError, PlatformSkippedWarning
from nnfmu.fmu.factory import BuildPlan
from nnfmu.fmu.model_description import instantiation_token, render_build_description, render_model_description
from nnfmu.fmu.native.codegen import UnsupportedGraphError, generate_c
from nnfmu.fmu.native.compiler import compile_all
from nnfmu.fmu.native.config import GraphLayout, port_map, render_config
from nnfmu.fmu.native.toolchain import select_targets
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


def write_native(plan: BuildPlan, tree: Path) -> None:
    """The native backend: generated C and the fixed glue under `sources/`, modelDescription.xml and one compiled
    binary per platform, written into the FMU folder `tree`. Raises FmuBuildError."""
    model, component, identifier, fmi = plan.model, plan.component, plan.identifier, plan.fmi_version
    try:
        generated = generate_c(model, prefix="nn")
    except UnsupportedGraphError as err:
        raise FmuBuildError(f"{plan.source}: {err}") from err
    layout = GraphLayout.of(model, generated.input_sizes, generated.output_sizes)
    ports = port_map(component, layout)
    token = instantiation_token(model.SerializeToString(), component, fmi)
    view = plan.view(token, source_files(fmi), directional_derivatives=generated.has_jvp)
    platforms, skipped = select_targets(plan.options.platforms)
    if skipped:
        warnings.warn(skipped, PlatformSkippedWarning, stacklevel=5)

    sources = tree / "sources"
    sources.mkdir(parents=True)
    glue = templates_dir() / "c"
    for name in (*GLUE_HEADERS, "nn_fmu.c", f"fmi{fmi}Functions.c"):
        shutil.copyfile(glue / name, sources / name)
    for name in FMI_HEADERS[fmi]:
        shutil.copyfile(fmi_headers_dir() / name, sources / name)
    config = render_config(component, plan.variables, ports, view.identity, plan.source_name)
    (sources / "config.h").write_text(config, encoding="utf-8")
    (sources / "graph.h").write_text(generated.header, encoding="utf-8")
    (sources / "graph.c").write_text(generated.source, encoding="utf-8")
    (sources / "buildDescription.xml").write_text(
        render_build_description(identifier, source_files(fmi)), encoding="utf-8"
    )
    (tree / "modelDescription.xml").write_text(render_model_description(view), encoding="utf-8")
    builds = [(t, tree / "binaries" / t.folder(fmi) / f"{identifier}{t.suffix}") for t in platforms]
    compile_all(builds, [sources / s for s in source_files(fmi)], sources)
