"""Characterisations linked from another workflow's report: each model into its own sub-folder, a relative link that
resolves to the report written, a model no standard test fits reported with its reason instead of raised; the quick
setting writes tables without figures; the road test's system report lists the links it is given."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import onnx

from nnfmu.export.graph import GraphBuilder
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.workflows.characterise.linked import LinkedCharacterisation, characterise_models
from nnfmu.workflows.characterise.settings import QUICK_SETTINGS
from nnfmu.workflows.roadtest.report import write_system_report

DAMPING = 2000.0  # [N.s/m]


def _damper(path: Path) -> Path:
    onnx.save(linear_damper_graph(DAMPING, 1e-3, "linear_damper", (-2.0, 2.0)), path)
    return path


def _neither(path: Path) -> Path:
    graph = GraphBuilder(reserved=["u", "y"])
    graph.output(graph.node("Identity", ["u"], "copy"), "y")
    onnx.save(graph.model("other", "y = u", [("u", 1)], [("y", 1)]), str(path))
    return path


def test_each_model_gets_its_report_or_its_reason(tmp_path: Path) -> None:
    models = {"damper": _damper(tmp_path / "damper.onnx"), "other": _neither(tmp_path / "other.onnx")}
    found = characterise_models(models, tmp_path / "out" / "characterise", QUICK_SETTINGS)
    damper, other = found["damper"], found["other"]
    assert damper.index == tmp_path / "out" / "characterise" / "damper" / "index.html" and damper.index.is_file()
    page = tmp_path / "out" / "report" / "quarter-car" / "index.html"
    assert damper.link(page) == "../../characterise/damper/index.html"
    assert (page.parent / damper.link(page)).resolve() == damper.index.resolve()
    assert other.index is None and other.link(page) is None
    assert "other.onnx: neither a damper" in other.reason and other.describe().startswith("not characterised: ")
    assert not (tmp_path / "out" / "characterise" / "other").exists()
    with (damper.index.parent / "characteristic.csv").open(encoding="utf-8") as stream:
        rows = list(csv.DictReader(stream))
    # F = c v: the quick series' three peak velocities, rebound c v and jounce -c v
    assert [float(r["peak_velocity [m/s]"]) for r in rows] == [0.1, 0.5, 1.0]
    for row in rows:
        v = float(row["peak_velocity [m/s]"])
        assert np.isclose(float(row["rebound_force [N]"]), DAMPING * v, rtol=1e-3)
        assert np.isclose(float(row["jounce_force [N]"]), -DAMPING * v, rtol=1e-3)
    assert not list(damper.index.parent.glob("*.png"))  # quick: tables only
    assert "figures: not drawn" in damper.index.read_text(encoding="utf-8")


def test_the_road_test_report_links_each_characterisation(tmp_path: Path) -> None:
    index = tmp_path / "characterise" / "damper-spline" / "index.html"
    index.parent.mkdir(parents=True)
    index.write_text("<html></html>", encoding="utf-8")
    summary = {
        "system": "quarter-car",
        "verdicts": [],
        "thesis_table": [],
        "budget": [],
        "envelope": [],
        "seconds": {},
        "ssds": {},
    }
    page = tmp_path / "report" / "quarter-car" / "index.html"
    found = {
        "damper-spline": LinkedCharacterisation(index),
        "lca-bushing": LinkedCharacterisation(None, "lca-bushing.fmu: 100 Hz leaves 5 samples a cycle"),
    }
    write_system_report(summary, {}, {}, page, found)
    html = page.read_text(encoding="utf-8")
    assert '<a href="../../characterise/damper-spline/index.html">damper-spline: characterisation report</a>' in html
    assert (page.parent / "../../characterise/damper-spline/index.html").is_file()
    assert "lca-bushing: not characterised (lca-bushing.fmu: 100 Hz leaves 5 samples a cycle)" in html
