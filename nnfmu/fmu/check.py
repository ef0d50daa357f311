"""`nnfmu check`: replay the reference results an FMU carries (FMI-LS-REF) with fmpy and compare every output.

Works for any FMU with the layered standard's layout, not only nnfmu's: the manifest
`extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml` lists experiment files (`<Related role="experiment...">`,
MA-HS-Experiments `.exp`); earlier drafts put `<Experiment>` elements in the manifest itself, which is read too. An
experiment's start, stop and step size come from its `<TransientSimulation>` child or, as in the format's document,
from attributes of `<Experiment>`; its parameters (SSV) become start values; its stimuli (CSV) are the inputs; every
column of its references (CSV, first column time) is compared at the reference times. An output passes when
max |simulated - reference| <= tolerance x its largest |reference| (tolerance alone for an all-zero reference);
the tolerance is the experiment's, else `DEFAULT_TOLERANCE`, unless the caller gives one. Related files with a
checksum must match it. An FMU that records its step graph (`step_graph.py`) has the embedded graph checked against
the sha256 its model description records.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import posixpath
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
from fmpy import read_model_description, simulate_fmu

from nnfmu.atomic import scratch_dir
from nnfmu.errors import NnfmuError
from nnfmu.fmu.reference_results import EXPERIMENTS_TYPE, LS_FOLDER, MANIFEST
from nnfmu.fmu.step_graph import StepGraphError, read_fmu_graph
from nnfmu.safe_zip import ArchiveError, check_members, extract_zip, open_zip

DEFAULT_TOLERANCE = 1e-6
CHECKSUMS = {
    "SHA3-224": hashlib.sha3_224,
    "SHA3-256": hashlib.sha3_256,
    "SHA3-384": hashlib.sha3_384,
    "SHA3-512": hashlib.sha3_512,
    "SHA-224": hashlib.sha224,
    "SHA-256": hashlib.sha256,
    "SHA-384": hashlib.sha384,
    "SHA-512": hashlib.sha512,
}
MANIFEST_PATH = f"{LS_FOLDER}/{MANIFEST}"
MAX_STEPS = 1_000_000  # communication steps of one experiment (nnfmu's own reference results have some hundreds)


MODEL_DESCRIPTION = "modelDescription.xml"


class CheckError(NnfmuError):
    """The FMU or its reference data cannot be read; the message names the file and what is wrong."""


@dataclass(frozen=True)
class OutputResult:
    """One reference column: the largest error, where it occurred, and what was allowed."""

    name: str
    max_error: float
    at_time: float
    allowed: float

    @property
    def passed(self) -> bool:
        return bool(self.max_error <= self.allowed)


@dataclass
class ExperimentResult:
    """One experiment replayed: its settings and each output's result (empty with `skipped` set when not run)."""

    name: str
    samples: int = 0
    step_size: float | None = None
    tolerance: float | None = None
    outputs: list[OutputResult] = field(default_factory=list)
    skipped: str = ""

    @property
    def passed(self) -> bool:
        return not self.skipped and all(o.passed for o in self.outputs)


@dataclass
class CheckReport:
    """The whole check: checksum problems, experiments, what the FMU's step graph record says; passes when nothing
    failed and at least one experiment ran."""

    fmu: Path
    checksum_errors: list[str] = field(default_factory=list)
    experiments: list[ExperimentResult] = field(default_factory=list)
    step_graph: str = ""

    @property
    def passed(self) -> bool:
        ran = [e for e in self.experiments if not e.skipped]
        return bool(ran) and not self.checksum_errors and all(e.passed for e in ran)


@dataclass(frozen=True)
class Experiment:
    """An experiment as read from its file; paths are archive paths."""

    name: str
    start: float | None
    stop: float | None
    step: float | None
    tolerance: float | None
    parameters: str | None
    stimuli: str | None
    references: str | None
    unsupported: str = ""


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _float(value: str | None, where: str) -> float | None:
    if value is None:
        return None
    try:
        return float(value)
    except ValueError:
        raise CheckError(f"{where}: {value!r} is not a number") from None


def _resolve(base: str, source: str, where: str) -> str | None:
    """Archive path of `source` relative to the archive file `base`; None for an absolute URI (not fetched)."""
    parsed = urlparse(source)
    if parsed.scheme or parsed.netloc:
        return None
    path = posixpath.normpath(posixpath.join(posixpath.dirname(base), unquote(parsed.path)))
    if path.startswith("../") or path == ".." or path.startswith("/"):
        raise CheckError(f"{where}: source {source!r} points outside the FMU")
    return path


class _Archive:
    """The FMU's files, read once."""

    def __init__(self, path: Path) -> None:
        try:
            with open_zip(path) as archive:
                members = check_members(archive, path)  # an FMU from elsewhere may be a zip bomb or climb out
                self.files = {info.filename: archive.read(info) for info in members if not info.is_dir()}
        except ArchiveError as err:
            raise CheckError(str(err)) from None
        except (OSError, zipfile.BadZipFile) as err:
            raise CheckError(f"{path}: not a readable FMU (zip archive): {err}") from err
        self.path = path

    def read(self, name: str, what: str) -> bytes:
        if name not in self.files:
            raise CheckError(f"{self.path}: {what} {name!r} is not in the FMU")
        return self.files[name]

    def xml(self, name: str, what: str) -> ET.Element:
        try:
            return ET.fromstring(self.read(name, what))
        except ET.ParseError as err:
            raise CheckError(f"{self.path}: {name} is not well-formed XML: {err}") from err


def _experiments_in(root: ET.Element, base: str, unsupported_type: str = "") -> list[Experiment]:
    experiments = []
    for element in (e for e in root if _local(e.tag) == "Experiment"):
        name = element.get("name") or f"experiment {len(experiments) + 1}"
        where = f"{base}: experiment {name!r}"
        timing = next((e.attrib for e in element if _local(e.tag) == "TransientSimulation"), element.attrib)
        parts: dict[str, str | None] = {"Parameters": None, "Stimuli": None, "References": None}
        unsupported = unsupported_type
        for child in element:
            tag = _local(child.tag)
            if tag in parts and child.get("source"):
                default = "application/x-ssp-parameter-set" if tag == "Parameters" else "text/csv"
                if child.get("type", default) != default:
                    unsupported = f"{tag} of type {child.get('type')!r} (nnfmu check reads {default})"
                parts[tag] = _resolve(base, child.get("source", ""), where)
        if any(
            _local(e.tag)
            in (
                "SteadyState",
                "ParameterOptimization",
                "SetPointOptimization",
                "SensitivityAnalysis",
                "TrajectoryOptimization",
                "Linearization",
            )
            for e in element
        ):
            unsupported = "not a transient simulation"
        experiments.append(
            Experiment(
                name,
                _float(timing.get("startTime"), where),
                _float(timing.get("stopTime"), where),
                _float(timing.get("stepSize"), where),
                _float(element.get("tolerance"), where),
                parts["Parameters"],
                parts["Stimuli"],
                parts["References"],
                unsupported,
            )
        )
    return experiments


def read_experiments(archive: _Archive) -> tuple[list[Experiment], list[str]]:
    """Every experiment the manifest leads to, and the checksum mismatches of its related files."""
    manifest = archive.xml(MANIFEST_PATH, "the FMI-LS-REF manifest")
    experiments = _experiments_in(manifest, MANIFEST_PATH)  # earlier drafts: experiments in the manifest
    checksum_errors = []
    for related in (e for e in manifest if _local(e.tag) == "Related"):
        path = _resolve(MANIFEST_PATH, related.get("source", ""), f"{MANIFEST_PATH}: <Related>")
        if path is None or path not in archive.files:
            continue
        if related.get("checksum"):
            kind = related.get("checksumType", "SHA3-256")
            digest = CHECKSUMS.get(kind)
            if digest is None:
                checksum_errors.append(f"{path}: unknown checksumType {kind!r}")
            elif digest(archive.files[path]).hexdigest().lower() != related.get("checksum", "").lower():
                checksum_errors.append(f"{path}: {kind} checksum does not match the manifest")
        role, mime = related.get("role", ""), related.get("type", "")
        if role.split("/")[0] == "experiment":
            known = mime in (EXPERIMENTS_TYPE, "application/x-ma-ls-experiments") or path.endswith(".exp")
            experiments += _experiments_in(
                archive.xml(path, "experiment file"), path, "" if known else f"experiment file of type {mime!r}"
            )
    return experiments, checksum_errors


def _table(archive: _Archive, path: str, what: str) -> tuple[list[str], np.ndarray]:
    """Header and float rows of a CSV time series (first column time)."""
    text = archive.read(path, what).decode("utf-8-sig")
    rows = [row for row in csv.reader(io.StringIO(text)) if row and any(cell.strip() for cell in row)]
    if len(rows) < 2:
        raise CheckError(f"{archive.path}: {path} needs a header and at least one row")
    header = [cell.strip() for cell in rows[0]]
    try:
        values = np.array([[float(cell) for cell in row] for row in rows[1:]], dtype=float)
    except ValueError as err:
        raise CheckError(f"{archive.path}: {path}: {err}") from err
    if values.shape[1] != len(header) or len(header) < 2:
        raise CheckError(f"{archive.path}: {path}: rows must have the {len(header)} columns of the header (>= 2)")
    if np.any(np.diff(values[:, 0]) < 0):
        raise CheckError(f"{archive.path}: {path}: time must not decrease")
    return header, values


def _parameters(archive: _Archive, path: str) -> dict[str, object]:
    """Start values from an SSV parameter set (Real, Integer, Boolean, String, Enumeration values)."""
    values: dict[str, object] = {}
    for parameter in (e for e in archive.xml(path, "parameter set").iter() if _local(e.tag) == "Parameter"):
        for value in parameter:
            kind, text = _local(value.tag), value.get("value")
            if text is None:
                continue
            if kind in ("Real", "Float64", "Float32"):
                values[parameter.get("name", "")] = float(text)
            elif kind in ("Integer", "Int32", "Int64"):
                values[parameter.get("name", "")] = int(text)
            elif kind == "Boolean":
                values[parameter.get("name", "")] = text.strip().lower() in ("true", "1")
            elif kind in ("String", "Enumeration"):
                values[parameter.get("name", "")] = text
    return values


def _check_span(where: str, start: float, stop: float, step: float | None) -> None:
    """CheckError naming the experiment unless start, stop and step are finite, the step positive and the steps from
    start to stop at most MAX_STEPS: counted before the FMU runs, so a hostile experiment cannot keep it busy."""
    for label, value in (("start time", start), ("stop time", stop), ("step size", step)):
        if value is not None and not math.isfinite(value):
            raise CheckError(f"{where}: {label} {value!r} s is not a finite number")
    if step is None:
        raise CheckError(f"{where}: no step size (neither the experiment nor the default experiment gives one)")
    if not step > 0:
        raise CheckError(f"{where}: step size {step!r} s must be positive")
    if not stop >= start:
        raise CheckError(f"{where}: stop time {stop!r} s lies before the start time {start!r} s")
    steps = (stop - start) / step
    if steps > MAX_STEPS:
        raise CheckError(
            f"{where}: stop time {stop:g} s from start {start:g} s in steps of {step:g} s is {steps:.3g} steps, "
            f"more than the {MAX_STEPS} a reference check runs"
        )


def _run(folder: str, experiment: Experiment, archive: _Archive, tolerance: float | None) -> ExperimentResult:
    """Simulate one experiment on the extracted FMU `folder` and compare its references."""
    result = ExperimentResult(experiment.name)
    if experiment.unsupported:
        result.skipped = experiment.unsupported
        return result
    if experiment.references is None:
        result.skipped = "no references"
        return result
    try:
        md = read_model_description(folder)
    except Exception as error:  # fmpy raises plain exceptions for malformed XML and missing attributes
        said = "; ".join(map(str, getattr(error, "problems", None) or [error]))  # fmpy's schema problems: one line
        raise CheckError(f"{archive.path}: cannot read its {MODEL_DESCRIPTION}: {' '.join(said.split())}") from None
    names = {v.name for v in md.modelVariables}
    header, reference = _table(archive, experiment.references, "references")
    unknown = [n for n in header[1:] if n not in names]
    if unknown:
        raise CheckError(f"{archive.path}: {experiment.references}: column(s) {unknown} name no FMU variable")
    signals = None
    if experiment.stimuli is not None:
        inputs, stimuli = _table(archive, experiment.stimuli, "stimuli")
        unknown = [n for n in inputs[1:] if n not in names]
        if unknown:
            raise CheckError(f"{archive.path}: {experiment.stimuli}: column(s) {unknown} name no FMU variable")
        signals = np.zeros(len(stimuli), dtype=[("time", float), *((n, float) for n in inputs[1:])])
        for i, name in enumerate(inputs):
            signals[name] = stimuli[:, i]
    times = reference[:, 0]
    default = md.defaultExperiment
    step = experiment.step or (
        _float(default.stepSize, f"{archive.path}: modelDescription.xml DefaultExperiment stepSize")
        if default and default.stepSize
        else None
    )
    if step is None:
        step = float(np.min(np.diff(times))) if len(times) > 1 else None
    start = experiment.start if experiment.start is not None else float(times[0])
    stop = experiment.stop if experiment.stop is not None else float(times[-1])
    _check_span(f"{archive.path}: experiment {experiment.name!r}", start, stop, step)
    parameters = _parameters(archive, experiment.parameters) if experiment.parameters else {}
    try:
        simulated = simulate_fmu(
            folder,
            start_time=start,
            stop_time=stop,
            step_size=step,
            output_interval=step,
            input=signals,
            output=header[1:],
            start_values=parameters,
        )
    except Exception as err:  # fmpy raises plain Exceptions for FMU errors
        raise CheckError(f"{archive.path}: experiment {experiment.name!r}: the simulation failed: {err}") from err
    tol = tolerance if tolerance is not None else (experiment.tolerance or DEFAULT_TOLERANCE)
    result.samples, result.step_size, result.tolerance = len(times), step, tol
    sim_time = np.asarray(simulated["time"], dtype=float)
    if times[0] < sim_time[0] - 1e-9 * max(1.0, abs(sim_time[0])) or times[-1] > sim_time[-1] + 1e-9 * max(
        1.0, abs(sim_time[-1])
    ):
        raise CheckError(
            f"{archive.path}: {experiment.references}: reference times {times[0]}..{times[-1]} s lie "
            f"outside the simulated {sim_time[0]}..{sim_time[-1]} s"
        )
    for i, name in enumerate(header[1:], start=1):
        got = np.interp(times, sim_time, np.asarray(simulated[name], dtype=float))
        error = np.abs(got - reference[:, i])
        worst = int(np.argmax(error))
        peak = float(np.max(np.abs(reference[:, i])))
        result.outputs.append(
            OutputResult(name, float(error[worst]), float(times[worst]), tol * peak if peak > 0 else tol)
        )
    return result


def check_fmu(path: str | Path, tolerance: float | None = None) -> CheckReport:
    """Replay every experiment of the FMU's FMI-LS-REF reference data; CheckError when there is none or it cannot
    be read."""
    path = Path(path)
    archive = _Archive(path)
    if MANIFEST_PATH not in archive.files:
        raise CheckError(f"{path}: no reference results ({MANIFEST_PATH} is not in the FMU)")
    if MODEL_DESCRIPTION not in archive.files:
        raise CheckError(f"{path}: no {MODEL_DESCRIPTION} in the FMU (every FMU holds one at its top level)")
    experiments, checksum_errors = read_experiments(archive)
    if not experiments:
        raise CheckError(f"{path}: {MANIFEST_PATH} lists no experiment")
    report = CheckReport(path, checksum_errors, step_graph=_step_graph(path, checksum_errors))
    with scratch_dir("nnfmu-check-") as folder:
        extract_zip(path, Path(folder))  # its members were checked when it was read
        for experiment in experiments:
            report.experiments.append(_run(folder, experiment, archive, tolerance))
    return report


def _step_graph(path: Path, checksum_errors: list[str]) -> str:
    """What the FMU's step graph record says; an altered or missing graph is added to `checksum_errors`."""
    try:
        found = read_fmu_graph(path)
    except StepGraphError as err:
        checksum_errors.append(str(err))
        return "altered or missing"
    if found is None:
        return "none recorded (an FMU of another tool or an older nnfmu)"
    data, record = found
    return f"{record.member} ({len(data)} bytes), sha256 as its model description records"


def report_lines(report: CheckReport) -> list[str]:
    """The report as the CLI prints it: the step graph, one line per experiment and per output, then the verdict."""
    lines = [f"step graph: {report.step_graph}"] if report.step_graph else []
    lines += [f"checksum: {problem}" for problem in report.checksum_errors]
    for experiment in report.experiments:
        if experiment.skipped:
            lines.append(f"experiment {experiment.name!r}: skipped ({experiment.skipped})")
            continue
        lines.append(
            f"experiment {experiment.name!r}: {experiment.samples} reference points, step "
            f"{experiment.step_size:g} s, tolerance {experiment.tolerance:g} x each output's peak"
        )
        for o in experiment.outputs:
            lines.append(
                f"  {o.name}: max error {o.max_error:.3g} at t = {o.at_time:g} s, allowed {o.allowed:.3g}: "
                f"{'pass' if o.passed else 'FAIL'}"
            )
    failed = [f"{o.name} (experiment {e.name!r})" for e in report.experiments for o in e.outputs if not o.passed]
    failed += ["checksums"] if report.checksum_errors else []
    lines.append("result: pass" if report.passed else f"result: FAIL: {', '.join(failed) or 'no experiment ran'}")
    return lines
