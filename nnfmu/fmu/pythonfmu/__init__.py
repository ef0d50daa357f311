"""The pythonfmu fallback backend: one fixed slave per FMI version (pythonfmu for 2.0, pythonfmu3 for 3.0) that runs
the ONNX step graph with onnxruntime through the shared `SampledComponent`."""

from nnfmu.fmu.pythonfmu.backend import write_pythonfmu
from nnfmu.fmu.pythonfmu.errors import PythonFmuBuildError

__all__ = ["PythonFmuBuildError", "write_pythonfmu"]
