"""Fix the named components: retrain a damper's network on its in-situ record through the component loop where the
lab measured its force and displacement, else add the effect's physical terms with the coefficients fitted to the
vehicle residual; either way a new FMU for the element."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nnfmu.cosim import replay_fmu
from nnfmu.data import Measurement
from nnfmu.data.derive import derivative
from nnfmu.diagnosis import Diagnosis, diagnose
from nnfmu.export import ExportError, read_step_graph
from nnfmu.workflows.loop import LoopReport, LoopSettings, run_loop
from nnfmu.workflows.vehicle_loop.attribution import Evidence
from nnfmu.workflows.vehicle_loop.sensitivity import term_fmu


def in_situ_record(measured: Measurement, element: str) -> Measurement | None:
    """The element's own record inside the car: its load cell as `force`, its LVDT as `displacement` and the
    velocity differentiated from it (Savitzky-Golay, `nnfmu.data.derive`); None unless both are measured."""
    force, displacement = f"{element}_force", f"{element}_displacement"
    if force not in measured or displacement not in measured:
        return None
    x = np.asarray(measured[displacement], dtype=float)
    return Measurement(
        measured.time.copy(),
        {"displacement": x, "velocity": derivative(x, measured.sample_period, 1), "force": measured[force]},
        {"displacement": "m", "velocity": "m/s", "force": "N"},
        source=f"{element} in-situ ({force}, {displacement}) in {measured.source}",
    )


def trained_network(onnx_path: Path) -> bool:
    """Whether `onnx_path` is a network nnfmu trained (its feature spec readable), which the component loop can
    diagnose and retrain; a hand-built step graph (the truth physics, a merged bushing) is not."""
    try:
        read_step_graph(onnx_path)
    except ExportError:
        return False
    return True


def in_situ_diagnosis(record: Measurement, fmu: Path, onnx_path: Path, settings: LoopSettings) -> Diagnosis:
    """The component loop's diagnosis of the element's network on its in-situ record (its FMU replayed on it)."""
    model, _ = read_step_graph(onnx_path)
    predicted = np.asarray(replay_fmu(fmu, record)["force"], dtype=float)
    return diagnose(record, predicted, "force", model.spec.channels, settings.diagnosis)


@dataclass(frozen=True)
class Fixed:
    """A component's new FMU and step graph, how it was made, and the component loop's report where it ran."""

    element: str
    fmu: Path
    onnx: Path
    method: str
    loop: LoopReport | None = None


def fix_in_situ(element: str, record: Measurement, onnx_path: Path, folder: Path, settings: LoopSettings) -> Fixed:
    """The component loop on the element's in-situ record, into `folder`."""
    report = run_loop(record, onnx_path, "force", folder, settings)
    method = f"component loop on the in-situ record: {report.summary}"
    return Fixed(element, report.fmu, report.onnx, method, report)


def fix_by_terms(evidence: Evidence, onnx_path: Path, folder: Path) -> Fixed:
    """The element's network with the effect's terms at the coefficients fitted to the vehicle residual."""
    terms = evidence.candidate.fitted_terms(evidence.coefficients)
    element = evidence.candidate.component
    graph, fmu = term_fmu(onnx_path, terms, folder / f"{element}-{evidence.candidate.effect}", "vehicle loop fix")
    listed = ", ".join(f"{t.coefficient:.4g} x {t.channel or '1'} on {t.output}" for t in terms)
    if evidence.candidate.joint_step is not None:
        listed = f"{evidence.coefficients[0]:+.1%} of its own stiffness: {listed}"
    return Fixed(element, fmu, graph, f"physical terms fitted to the vehicle residual: {listed}")
