"""Reference results inside an FMU (FMI-LS-REF): stimuli and the outputs the ONNX graph computes from them.

From the reference stimulus in the ONNX metadata (`nnfmu.reference_stimulus`) the build writes, under
`extra/org.fmi-standard.fmi-ls-ref/`: the manifest `fmi-ls-manifest.xml` (FMI-LS-REF 1.0.0-alpha.1: one `<Related>`
per file, SHA3-256 checksums), the experiment `reference.exp` (MA-HS-Experiments: `<TransientSimulation>` with start,
stop and step size, `tolerance`), `stimuli.csv` and `references.csv` (header `time,<variable>,...`, one row per
communication point), and `documentation/fmi-ls-ref.txt`. The expected outputs are onnxruntime's, run through the FMU
semantics of docs/fmu.md at the FMU's default parameters, as a master that sets stimulus row k at t_k and steps by
the sample period sees them: they verify that the FMU implements its graph (model accuracy is in the ONNX metadata's
metrics). Graphs without a stimulus or a sample period get no reference results.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx

from nnfmu.component import Component
from nnfmu.export.step_runner import run_step_graph
from nnfmu.fmu.errors import FmuBuildError
from nnfmu.fmu.variables import FmuVariables
from nnfmu.reference_stimulus import ReferenceStimulus

LS_NAME = "org.fmi-standard.fmi-ls-ref"
LS_FOLDER = f"extra/{LS_NAME}"
LS_VERSION = "1.0.0-alpha.1"
LS_DESCRIPTION = "Layered Standard providing information on related files included in an FMU."
LS_NAMESPACE = "http://fmi-standard.org/fmi-ls-manifest"
MANIFEST = "fmi-ls-manifest.xml"
EXPERIMENTS_TYPE = "application/x-ma-hs-experiments"
EXPERIMENTS_FILE = "reference.exp"
STIMULI_FILE = "stimuli.csv"
REFERENCES_FILE = "references.csv"
DOCUMENTATION_FILE = "documentation/fmi-ls-ref.txt"
# Allowed error of each output, relative to its largest magnitude over the experiment. The native FMU reproduces
# onnxruntime to ~1e-15 (linux64 and win64); a changed weight moves outputs by far more than 1e-9 of their range.
TOLERANCE = 1e-9


@dataclass(frozen=True)
class ReferenceRun:
    """Stimuli and expected outputs on the grid t_k = k T (FMU variable name -> values), and where they come from."""

    period: float
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    source: str

    @property
    def times(self) -> list[float]:
        return [k * self.period for k in range(len(next(iter(self.inputs.values()))))]


def stored_stimulus(model: onnx.ModelProto, where: str) -> ReferenceStimulus | None:
    """The graph's reference stimulus, or None; FmuBuildError naming `where` when it is malformed."""
    try:
        return ReferenceStimulus.from_onnx(model)
    except ValueError as err:
        raise FmuBuildError(f"{where}: {err}") from err


def reference_run(
    model: onnx.ModelProto, component: Component, variables: FmuVariables, stimulus: ReferenceStimulus
) -> ReferenceRun | None:
    """What the FMU must report for `stimulus`, or None when the graph has no sample period or the stimulus lacks an
    input port. Sample 0 sees stimulus row 0; sample k >= 1 the row k-1 set before doStep(t_{k-1}, T); then the
    first-order output filter at the FMU's default `filter_cutoff` and `output_gain`."""
    period = component.sample_period
    if period is None or any(port.name not in stimulus.inputs for port in component.inputs):
        return None
    given = {port.name: np.asarray(stimulus.inputs[port.name], dtype=float) for port in component.inputs}
    held = {name: np.concatenate([values[:1], values[:-1]]) for name, values in given.items()}
    raw = run_step_graph(model, held)
    cutoff = float(variables.filter_cutoff.start or 0.0)
    gain = float(variables.output_gain.start if variables.output_gain.start is not None else 1.0)
    a = 1.0 if cutoff <= 0.0 else 1.0 - math.exp(-2.0 * math.pi * cutoff * period)
    outputs: dict[str, np.ndarray] = {}
    for variable in variables.outputs:
        u = gain * raw[component.outputs[variable.port_index].name]
        y = np.empty_like(u)
        y[0] = u[0]
        for k in range(1, len(u)):
            y[k] = y[k - 1] + a * (u[k] - y[k - 1])
        outputs[variable.name] = y
    inputs = {v.name: given[component.inputs[v.port_index].name] for v in variables.inputs}
    return ReferenceRun(period, inputs, outputs, stimulus.source)


def _csv(times: list[float], columns: dict[str, np.ndarray]) -> bytes:
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["time", *columns])
    for k, t in enumerate(times):
        writer.writerow([repr(float(t)), *(repr(float(values[k])) for values in columns.values())])
    return text.getvalue().encode("utf-8")


def _xml(root: ET.Element) -> bytes:
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def _experiments(run: ReferenceRun, component: Component) -> bytes:
    root = ET.Element(
        "Experiments",
        name=f"{component.name} reference results",
        description="nnfmu: the ONNX graph's outputs for a stored input record, to verify the FMU",
    )
    experiment = ET.SubElement(
        root,
        "Experiment",
        name="reference",
        tolerance=repr(TOLERANCE),
        description=f"stimuli: {run.source}; references: onnxruntime on the ONNX graph",
    )
    times = run.times
    ET.SubElement(
        experiment, "TransientSimulation", startTime=repr(times[0]), stopTime=repr(times[-1]), stepSize=repr(run.period)
    )
    ET.SubElement(experiment, "Stimuli", source=STIMULI_FILE, type="text/csv")
    ET.SubElement(experiment, "References", source=REFERENCES_FILE, type="text/csv")
    return _xml(root)


def _manifest(files: dict[str, tuple[bytes, str, str, str]]) -> bytes:
    ET.register_namespace("fmi-ls", LS_NAMESPACE)
    root = ET.Element(
        "fmiReferences",
        {
            f"{{{LS_NAMESPACE}}}fmi-ls-name": LS_NAME,
            f"{{{LS_NAMESPACE}}}fmi-ls-version": LS_VERSION,
            f"{{{LS_NAMESPACE}}}fmi-ls-description": LS_DESCRIPTION,
        },
    )
    for source, (content, mime, role, description) in files.items():
        ET.SubElement(
            root,
            "Related",
            type=mime,
            source=source,
            role=role,
            description=description,
            checksum=hashlib.sha3_256(content).hexdigest(),
            checksumType="SHA3-256",
        )
    return _xml(root)


def _documentation(run: ReferenceRun, component: Component) -> bytes:
    n = len(run.times)
    return (
        f"Reference results of {component.name} (FMI-LS-REF {LS_VERSION}, extra/{LS_NAME}/)\n\n"
        f"Experiment 'reference' in {EXPERIMENTS_FILE}: {n} communication points, step size = the sample period "
        f"{run.period!r} s, from t = 0 at the FMU's default parameters.\n"
        f"Stimuli ({STIMULI_FILE}): {run.source}. Set row k before the step from t_k.\n"
        f"References ({REFERENCES_FILE}): the outputs after each step (row 0: after initialisation), computed by "
        "onnxruntime from the ONNX graph the FMU was built from, through the FMU's sampling and output filter. "
        "They verify that the FMU computes its graph; how well the model fits the measurement is in the ONNX "
        "file's metrics.\n"
        f"Pass: for every output, max |simulated - reference| <= tolerance ({TOLERANCE:g}) x the output's largest "
        "|reference| over the experiment. Check with: nnfmu check FMU\n"
    ).encode("utf-8")


def has_reference_results(fmu: Path) -> bool:
    """Whether the FMU file carries an FMI-LS-REF manifest."""
    with zipfile.ZipFile(fmu) as archive:
        return f"{LS_FOLDER}/{MANIFEST}" in archive.namelist()


def write_reference_results(tree: Path, model: onnx.ModelProto, component: Component, variables: FmuVariables) -> bool:
    """Write the reference results into the FMU folder `tree` if the graph carries a stimulus; True if written."""
    stimulus = stored_stimulus(model, component.name)
    run = None if stimulus is None else reference_run(model, component, variables, stimulus)
    if run is None:
        return False
    files = {
        EXPERIMENTS_FILE: (
            _experiments(run, component),
            EXPERIMENTS_TYPE,
            "experiment/smoke-test",
            "stimuli and expected outputs of the ONNX graph",
        ),
        STIMULI_FILE: (_csv(run.times, run.inputs), "text/csv", "other", "stimuli of the experiment"),
        REFERENCES_FILE: (_csv(run.times, run.outputs), "text/csv", "result", "expected outputs (onnxruntime)"),
        f"../../{DOCUMENTATION_FILE}": (
            _documentation(run, component),
            "text/plain",
            "document",
            "what the reference results are and how they are checked",
        ),
    }
    folder = tree / LS_FOLDER
    folder.mkdir(parents=True, exist_ok=True)
    for source, (content, *_) in files.items():
        target = (folder / source).resolve()
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(content)
    (folder / MANIFEST).write_bytes(_manifest(files))
    return True
