"""The ONNX round trip: a step graph exported by nnfmu reads back into a model that predicts what the graph computes
and exports to the same graph again; graphs it cannot read back are refused naming what is missing."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import numpy_helper

sys.path.insert(0, str(Path(__file__).parent))
from test_export import MLP_SPEC, make_model, signals  # noqa: E402

from nnfmu.component import METADATA_KEY, replace_metadata  # noqa: E402
from nnfmu.export import ExportError, export_onnx, read_step_graph, run_step_graph  # noqa: E402
from nnfmu.export.initializers import MLP_INITIALIZERS, SCALER_INITIALIZERS  # noqa: E402


def initializers(path: Path) -> dict[str, np.ndarray]:
    return {t.name: numpy_helper.to_array(t) for t in onnx.load(str(path)).graph.initializer}


def test_a_model_read_back_predicts_what_its_graph_computes_and_exports_to_the_same_graph(tmp_path):
    model = make_model(MLP_SPEC, recurrent=False)
    first = tmp_path / "first.onnx"
    export_onnx(model, first)
    loaded, component = read_step_graph(first)
    assert loaded.spec == model.spec and loaded.sample_period == model.sample_period and loaded.band == model.band
    assert component.sample_period == model.sample_period
    x = signals(MLP_SPEC.channels, 400, seed=7)
    np.testing.assert_allclose(loaded.predict(x), run_step_graph(first, x)["force"], rtol=1e-10, atol=1e-9)
    second = tmp_path / "second.onnx"
    export_onnx(loaded, second)
    before, after = initializers(first), initializers(second)
    assert set(MLP_INITIALIZERS + SCALER_INITIALIZERS) <= set(before) and before.keys() == after.keys()
    for name in before:
        np.testing.assert_allclose(after[name], before[name], rtol=1e-12, atol=1e-12, err_msg=name)


def test_graphs_that_cannot_be_read_back_are_refused_naming_why(tmp_path):
    with pytest.raises(ExportError, match="no such model file"):
        read_step_graph(tmp_path / "absent.onnx")
    (tmp_path / "junk.onnx").write_bytes(b"not onnx")
    with pytest.raises(ExportError, match="not a readable ONNX file"):
        read_step_graph(tmp_path / "junk.onnx")
    recurrent = tmp_path / "gru.onnx"
    export_onnx(make_model(MLP_SPEC, recurrent=True), recurrent)
    with pytest.raises(ExportError, match="network kind 'gru'; only MLP"):
        read_step_graph(recurrent)
    path = tmp_path / "mlp.onnx"
    export_onnx(make_model(MLP_SPEC, recurrent=False), path)
    graph = onnx.load(str(path))
    kept = [t for t in graph.graph.initializer if t.name != MLP_INITIALIZERS[0]]
    del graph.graph.initializer[:]
    graph.graph.initializer.extend(kept)
    onnx.save(graph, str(tmp_path / "cut.onnx"))
    with pytest.raises(ExportError, match=f"initializer\\(s\\) {MLP_INITIALIZERS[0]} missing"):
        read_step_graph(tmp_path / "cut.onnx")


def test_malformed_metadata_is_refused_as_an_export_error(tmp_path):
    """A description or feature spec another tool (or a hand edit) broke is an ExportError naming the file and the
    field, not a bare ValueError: the loop reports it as the user's input."""
    path = tmp_path / "mlp.onnx"
    export_onnx(make_model(MLP_SPEC, recurrent=False), path)
    graph = onnx.load(str(path))
    description = json.loads(next(p.value for p in graph.metadata_props if p.key == METADATA_KEY))
    replace_metadata(graph, METADATA_KEY, "[1, 2]")
    onnx.save(graph, str(tmp_path / "list.onnx"))
    with pytest.raises(ExportError, match=r"list\.onnx: cannot read the component description: .*JSON list"):
        read_step_graph(tmp_path / "list.onnx")
    description["metadata"]["feature_spec"] = {"output": "force"}
    replace_metadata(graph, METADATA_KEY, json.dumps(description))
    onnx.save(graph, str(tmp_path / "spec.onnx"))
    with pytest.raises(ExportError, match=r"spec\.onnx: cannot read the feature spec: .*'taps'"):
        read_step_graph(tmp_path / "spec.onnx")


def test_the_training_band_reads_back_and_a_graph_without_one_has_none(tmp_path):
    """An older graph carries no band (its report then judges test points by range alone); a malformed one is
    refused naming the input and value."""
    path = tmp_path / "mlp.onnx"
    export_onnx(make_model(MLP_SPEC, recurrent=False), path)
    graph = onnx.load(str(path))
    description = json.loads(next(p.value for p in graph.metadata_props if p.key == METADATA_KEY))
    del description["metadata"]["training_band"]
    replace_metadata(graph, METADATA_KEY, json.dumps(description))
    onnx.save(graph, str(tmp_path / "older.onnx"))
    assert read_step_graph(tmp_path / "older.onnx")[0].band == {}
    description["metadata"]["training_band"] = {"power_share": 0.99, "upper_edge_Hz": {"velocity": float("nan")}}
    replace_metadata(graph, METADATA_KEY, json.dumps(description))
    onnx.save(graph, str(tmp_path / "nan.onnx"))
    with pytest.raises(ExportError, match="training band of input 'velocity' is nan"):
        read_step_graph(tmp_path / "nan.onnx")
