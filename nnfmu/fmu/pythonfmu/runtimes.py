"""The two pythonfmu runtimes: pythonfmu for FMI 2.0, pythonfmu3 (optional, alpha) for FMI 3.0, with nnfmu's slave
for each and the CoSimulation flags that slave supports."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from nnfmu.fmu.pythonfmu.errors import PythonFmuBuildError

PYTHONFMU3_PIN = "pythonfmu3==0.3.4"  # the FMI 3 runtime this backend is tested with (see fmi3_slave.py)


@dataclass(frozen=True)
class Runtime:
    """What differs between FMI versions: the runtime package shipped in the FMU (its name for generationTool), the
    slave file and class that run on it, and the CoSimulation flags the slave supports there."""

    package: ModuleType
    name: str
    slave_file: Path
    slave_class: type
    capabilities: dict[str, bool]

    @property
    def directory(self) -> Path:
        """The package's folder: its `*.py` go into the FMU's resources, its prebuilt libraries into binaries."""
        return Path(self.package.__file__).resolve().parent


def runtime(fmi_version: int) -> Runtime:
    """The pythonfmu runtime of `fmi_version`; PythonFmuBuildError naming the package when FMI 3's is missing."""
    if fmi_version == 2:
        import pythonfmu

        from nnfmu.fmu.pythonfmu import fmi2_slave

        return Runtime(
            pythonfmu,
            "PythonFMU",
            Path(fmi2_slave.__file__),
            fmi2_slave.NnfmuSlave,
            {
                "needsExecutionTool": True,
                "canHandleVariableCommunicationStepSize": True,
                "canInterpolateInputs": False,
                "canBeInstantiatedOnlyOncePerProcess": False,
                "canGetAndSetFMUstate": True,
                "canSerializeFMUstate": True,
            },
        )
    try:
        import pythonfmu3
    except ImportError as err:
        raise PythonFmuBuildError(
            f"the pythonfmu backend needs the package pythonfmu3 for FMI 3.0 (pip install {PYTHONFMU3_PIN}): {err}"
        ) from err
    from nnfmu.fmu.pythonfmu import fmi3_slave

    return Runtime(
        pythonfmu3,
        "PythonFMU3",
        Path(fmi3_slave.__file__),
        fmi3_slave.NnfmuSlave3,
        {
            "needsExecutionTool": True,
            "canHandleVariableCommunicationStepSize": True,
            "canBeInstantiatedOnlyOncePerProcess": False,
            "canGetAndSetFMUState": True,
            "canSerializeFMUState": True,
        },
    )
