"""`nnfmu build`: turn an ONNX step graph into an FMU with the chosen backend (native C by default).

Two entries, one factory (`nnfmu.fmu.factory`): `build_fmu` reads an ONNX file (errors name the file),
`build_fmu_from_model` takes the graph in memory (the vehicle build); both plan the build once and hand the plan to
the backend of `options.backend`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import onnx

from nnfmu.component import Component
from nnfmu.fmu.factory import Backend, BuildPlan, assemble, default_output, load_onnx, plan_build
from nnfmu.fmu.options import BuildOptions


def backend_of(options: BuildOptions) -> Backend:
    """The backend function of `options.backend` (imported on use: pythonfmu needs onnxruntime, native a compiler)."""
    if options.backend == "pythonfmu":
        from nnfmu.fmu.pythonfmu import write_pythonfmu

        return write_pythonfmu
    from nnfmu.fmu.native.backend import write_native

    return write_native


def build_fmu(onnx_path: Path, options: BuildOptions | None = None) -> Path:
    """Build an FMU from the ONNX file `onnx_path` and return its path (without `options.out`: `exported/` with the
    file's name, `damper.onnx` -> `exported/damper.fmu`, whatever component name the graph carries); any failure
    raises FmuBuildError naming the file and writes no `.fmu`."""
    onnx_path = Path(onnx_path)
    options = options or BuildOptions()
    if options.out is None:
        options = replace(options, out=default_output(onnx_path.stem))
    plan = plan_build(load_onnx(onnx_path), options, source=str(onnx_path), source_name=onnx_path.name)
    return _build(plan)


def build_fmu_from_model(
    model: onnx.ModelProto, options: BuildOptions | None = None, component: Component | None = None
) -> Path:
    """Build an FMU from the in-memory graph `model` (described by `component`, default the graph's own metadata)
    and return its path; any failure raises FmuBuildError and writes no `.fmu`. `model` is not modified."""
    return _build(plan_build(model, options or BuildOptions(), component))


def _build(plan: BuildPlan) -> Path:
    return assemble(plan, backend_of(plan.options))
