"""Export a trained model as a self-contained ONNX step graph with its `Component` in the metadata, checked first."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx

import nnfmu
from nnfmu.atomic import atomic_path
from nnfmu.component import Component
from nnfmu.export.metadata import build_component
from nnfmu.export.step_graph import build_step_graph, network_sizes, state_layout
from nnfmu.export.verify import envelope_signal, verify_step_graph
from nnfmu.models.trained import TrainedModel
from nnfmu.reference_stimulus import REFERENCE_SAMPLES, ReferenceStimulus


@dataclass(frozen=True)
class ExportResult:
    """What was written: the file, its component description, and how closely it reproduced the torch model."""

    path: Path
    component: Component
    max_relative_error: float
    verified_samples: int
    verified_on: str


def _graph_doc(model: TrainedModel, component: Component) -> str:
    kind, sizes = network_sizes(model)
    inputs = ", ".join(f"{p.name} [{p.unit}]" for p in component.inputs)
    out = component.outputs[0]
    slots = [slot.name for slot in state_layout(model)]
    state = f"; state [{len(slots)}] = {', '.join(slots)}" if slots else ""
    return (
        f"nnfmu {nnfmu.__version__} step function: one sample (T = {model.sample_period:g} s) of {out.name} "
        f"[{out.unit}] "
        f"from {inputs}{state}. Features {model.spec.feature_names} are min-max scaled to [-1, 1] inside the graph "
        f"and fed to a {kind.upper()} {sizes}; the output is unscaled to SI units."
    )


def export_onnx(
    model: TrainedModel,
    path: str | os.PathLike[str],
    *,
    name: str = "",
    description: str = "",
    verify_on: dict[str, np.ndarray] | None = None,
) -> ExportResult:
    """Write `model`'s step graph to `path` after checking onnxruntime reproduces `model.predict` (relative error
    <= 1e-6).

    `verify_on` is the test split's input channels; without it the check runs on random samples inside the training
    envelope. The first samples of the checked inputs go into the metadata as the reference stimulus `nnfmu build`
    turns into the FMU's reference results. Nothing is written if any check fails (ExportError, or onnx's
    ValidationError for a malformed graph).
    """
    name = name or f"{model.spec.output}_model"
    component = build_component(
        model, name, description or f"{model.spec.output} of a component, learnt from rig data by nnfmu"
    )
    onnx_model = build_step_graph(model, name, _graph_doc(model, component))
    onnx_model.producer_version = nnfmu.__version__
    onnx_model.doc_string = component.description
    component.attach_to(onnx_model)
    onnx.checker.check_model(onnx_model, full_check=True)
    if verify_on is None:
        channels, source = envelope_signal(model), "random samples inside the training envelope"
    else:
        channels, source = verify_on, "given channels"
    error, samples = verify_step_graph(onnx_model, model, channels)
    names = [p.name for p in component.inputs]
    n = min(REFERENCE_SAMPLES, len(channels[names[0]]))
    what = "the input data" if verify_on is not None else "the random inputs inside the training envelope"
    ReferenceStimulus.take(channels, names, f"the first {n} samples of {what} the export was verified on", n).attach_to(
        onnx_model
    )
    path = Path(path)
    with atomic_path(path) as tmp:
        onnx.save(onnx_model, tmp)
    return ExportResult(
        path=path, component=component, max_relative_error=error, verified_samples=samples, verified_on=source
    )
