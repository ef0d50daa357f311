"""The pythonfmu backend of the FMU factory: the step graph as a pythonfmu (FMI 2.0) or pythonfmu3 (FMI 3.0) FMU.

The FMU holds `resources/model.onnx` (with the component description in its metadata), `resources/variables.json`
(nnfmu's variable table), the fixed slave module of its FMI version (`fmi2_slave.py` or `fmi3_slave.py`) copied as
`resources/<module>.py`, the shared semantics `sampled_component.py` copied as `resources/<module>_core.py`, and the
runtime package. The module name is `nnfmu_slave_` plus a hash of both files, the graph and the table: Python
caches modules by name in `sys.modules`, so two different FMUs in one process must not share one. The copies are
byte-identical: no Python is generated.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import uuid
import xml.etree.ElementTree as ET
from dataclasses import asdict
from pathlib import Path

import onnx
from onnxruntime.capi.onnxruntime_pybind11_state import Fail, InvalidArgument, InvalidGraph
from onnxruntime.capi.onnxruntime_pybind11_state import NotImplemented as OrtNotImplemented

from nnfmu.fmu.factory import BuildPlan
from nnfmu.fmu.model_description import GENERATION_TOOL, ModelDescriptionView
from nnfmu.fmu.pythonfmu import sampled_component
from nnfmu.fmu.pythonfmu.errors import PythonFmuBuildError
from nnfmu.fmu.pythonfmu.model_description_fix import DescriptionFix, fix_model_description
from nnfmu.fmu.pythonfmu.runtimes import Runtime, runtime
from nnfmu.fmu.variables import FmuVariables

RUNTIME_NOTE = (
    "pythonfmu backend: runs in the importing tool's Python 3 process, which needs numpy and onnxruntime installed"
)
ORT_ERRORS = (Fail, InvalidArgument, InvalidGraph, OrtNotImplemented)


def write_pythonfmu(plan: BuildPlan, tree: Path) -> None:
    """The pythonfmu backend: the graph with its component attached, the variable table, the fixed slave and the
    runtime under `resources/`, the runtime's binaries and modelDescription.xml, written into the FMU folder `tree`.
    Raises PythonFmuBuildError (an FmuBuildError)."""
    run = runtime(plan.fmi_version)
    component = plan.component
    if component.interpolates_inputs:
        raise PythonFmuBuildError(
            f"{plan.source}: {component.name!r} interpolates its inputs between samples (a vehicle), which the "
            "pythonfmu runtimes cannot offer (no input derivatives, no evaluation of the latest sample when inputs "
            "are set after a step); build it with the native backend"
        )
    model = onnx.ModelProto()
    model.CopyFrom(plan.model)
    component.attach_to(model)  # the slave reads its ports from here, also for graphs from other tools
    module = _write_resources(tree / "resources", model, plan.variables, run, plan.fmi_version)
    view = plan.view(_guid(module))
    (tree / "modelDescription.xml").write_bytes(_model_description(tree / "resources", view, run))
    _copy_binaries(tree / "binaries", plan.identifier, run)


def _guid(module: str) -> str:
    """The FMU's GUID / instantiation token, from the content hash in the module name (same files: same token)."""
    return "{" + str(uuid.UUID(hashlib.sha256(module.encode("utf-8")).hexdigest()[:32])) + "}"


def _write_resources(
    resources: Path, model: onnx.ModelProto, variables: FmuVariables, run: Runtime, fmi_version: int
) -> str:
    """Write the graph, the variable table, the slave and its core under a unique module name, and the runtime
    package; return the module name."""
    resources.mkdir(parents=True)
    graph = model.SerializeToString()
    listed = [asdict(v) for v in variables.listed(fmi_version)]
    table = json.dumps({"variables": listed}, indent=1, sort_keys=True)
    slave_source = run.slave_file.read_bytes()
    core_source = Path(sampled_component.__file__).read_bytes()
    digest = hashlib.sha256(slave_source + core_source + graph + table.encode("utf-8")).hexdigest()
    module = f"nnfmu_slave_{digest[:16]}"

    (resources / sampled_component.MODEL_FILE).write_bytes(graph)
    (resources / sampled_component.VARIABLES_FILE).write_text(table, encoding="utf-8")
    (resources / f"{module}.py").write_bytes(slave_source)
    (resources / f"{module}_core.py").write_bytes(core_source)
    (resources / "slavemodule.txt").write_text(module, encoding="utf-8")
    package = resources / run.directory.name
    package.mkdir()
    for source in sorted(run.directory.glob("*.py")):
        shutil.copy2(source, package / source.name)
    return module


def _model_description(resources: Path, view: ModelDescriptionView, run: Runtime) -> bytes:
    """The runtime's description of the slave instantiated on `resources`, completed by `fix_model_description`."""
    name = view.component.name
    try:
        slave = run.slave_class(instance_name="nnfmu_build", resources=str(resources))
    except ORT_ERRORS as err:
        raise PythonFmuBuildError(f"{name}: onnxruntime cannot load the graph: {err}") from err
    except ValueError as err:  # the component description does not fit the graph
        raise PythonFmuBuildError(f"{name}: {err}") from err
    slave.modelName = view.identifier
    slave.guid = view.token
    root = slave.to_xml(run.capabilities)
    text = view.component.description or f"nnfmu component {name}"
    tool = f"{GENERATION_TOOL} ({run.name} {run.package.__version__})"
    fix_model_description(root, DescriptionFix(view, f"{text} ({RUNTIME_NOTE})", tool, run.capabilities))
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def _copy_binaries(binaries: Path, identifier: str, run: Runtime) -> None:
    """The runtime's prebuilt libraries, renamed to the model identifier as FMI requires."""
    for library in sorted((run.directory / "resources" / "binaries").glob("*/*")):
        if library.suffix in {".so", ".dll", ".dylib"}:
            target = binaries / library.parent.name / f"{identifier}{library.suffix}"
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(library, target)
