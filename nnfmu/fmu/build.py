"""`nnfmu build`: turn an ONNX step graph into an FMU with the chosen backend (native C by default)."""

from __future__ import annotations

from pathlib import Path

from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.options import BuildOptions


def build_fmu(onnx_path: Path, options: BuildOptions | None = None) -> Path:
    """Build an FMU from `onnx_path` and return its path; any failure raises FmuBuildError and writes no `.fmu`."""
    options = options or BuildOptions()
    if not Path(onnx_path).is_file():
        raise FmuBuildError(f"{onnx_path}: no such ONNX file")
    if options.backend == "pythonfmu":
        from nnfmu.fmu.pythonfmu import PythonFmuBuildError, build_pythonfmu

        try:
            return build_pythonfmu(Path(onnx_path), options)
        except PythonFmuBuildError as err:
            raise FmuBuildError(str(err)) from err
    from nnfmu.fmu.native.build import build_native

    return build_native(Path(onnx_path), options)
