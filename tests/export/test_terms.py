"""Physical terms added to a step graph's output: the graph computes network + terms, a new channel becomes an input
port, and bad terms are refused by name."""

from __future__ import annotations

import numpy as np
import onnxruntime as ort
import pytest

from nnfmu.component import Component
from nnfmu.export.errors import ExportError
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.export.terms import OutputTerm, add_output_terms


def run(model, **inputs: float) -> float:
    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    feed = {name: np.array([value]) for name, value in inputs.items()}
    return float(session.run(["force"], feed)[0][0])


def test_terms_add_a_preload_and_a_rate_on_a_new_displacement_input() -> None:
    damper = linear_damper_graph(2500.0, 1e-3, "linear_damper", (-2.0, 2.0))
    terms = [OutputTerm("force", None, -250.0, "N"), OutputTerm("force", "displacement", 1000.0, "m")]
    extended = add_output_terms(damper, terms)
    for v, x in ((0.3, 0.01), (-1.2, -0.02), (0.0, 0.0)):
        assert run(extended, velocity=v, displacement=x) == pytest.approx(2500.0 * v - 250.0 + 1000.0 * x)
        assert run(damper, velocity=v) == pytest.approx(2500.0 * v)
    component = Component.from_onnx(extended)
    assert [p.name for p in component.inputs] == ["velocity", "displacement"]
    assert component.inputs[1].unit == "m" and component.inputs[1].min is None
    assert len(component.metadata["added_terms"]) == 2


@pytest.mark.parametrize(
    ("term", "message"),
    [
        (OutputTerm("torque", None, 1.0), "no output 'torque'"),
        (OutputTerm("force", "force", 1.0), "not an input port"),
    ],
)
def test_bad_terms_are_refused_by_name(term: OutputTerm, message: str) -> None:
    with pytest.raises(ExportError, match=message):
        add_output_terms(linear_damper_graph(2500.0, 1e-3, "linear_damper", (-2.0, 2.0)), [term])


def test_a_coefficient_must_be_finite() -> None:
    with pytest.raises(ExportError, match="must be finite"):
        OutputTerm("force", None, float("inf"))
