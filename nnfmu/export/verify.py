"""The export cross-check: the step graph in onnxruntime must reproduce the torch model sample by sample."""

from __future__ import annotations

import numpy as np
import onnx

from nnfmu.export.errors import ExportError
from nnfmu.export.step_runner import run_step_graph
from nnfmu.models.trained import TrainedModel

# float64 graph and float64 torch: differences are rounding only (~1e-15); 1e-6 is the acceptance bound.
MAX_RELATIVE_ERROR = 1e-6


def relative_error(result: np.ndarray, reference: np.ndarray) -> float:
    """max|result - reference| / max|reference|; the absolute error when the reference is all zero."""
    scale = float(np.max(np.abs(reference))) if reference.size else 0.0
    diff = float(np.max(np.abs(result - reference))) if reference.size else 0.0
    return diff / scale if scale > 0 else diff


def envelope_signal(model: TrainedModel, n: int = 200, seed: int = 0) -> dict[str, np.ndarray]:
    """Deterministic random samples inside each input channel's training envelope, for exports given no test data."""
    rng = np.random.default_rng(seed)
    return {c: rng.uniform(*model.envelope[c], size=n) for c in model.spec.channels}


def verify_step_graph(
    graph: onnx.ModelProto, model: TrainedModel, channels: dict[str, np.ndarray]
) -> tuple[float, int]:
    """(relative error, samples) of the graph's output against `model.predict` over `channels`.

    Raises ExportError when the error exceeds MAX_RELATIVE_ERROR or there are no samples.
    """
    output = model.spec.output
    reference = np.asarray(model.predict(channels), dtype=np.float64)
    if reference.size == 0:
        raise ExportError("verification needs at least one sample of every input channel")
    result = run_step_graph(graph, channels)[output]
    error = relative_error(result, reference)
    if not error <= MAX_RELATIVE_ERROR:
        worst = int(np.argmax(np.abs(result - reference)))
        raise ExportError(
            f"step graph output {output!r} differs from the torch model: relative error {error:.3g} > "
            f"{MAX_RELATIVE_ERROR:g} (worst at sample {worst}: onnx {float(result[worst])!r}, "
            f"torch {float(reference[worst])!r})"
        )
    return error, reference.size
