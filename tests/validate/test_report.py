"""The report folder: PNGs, summary.json with definitions, an escaped index.html; staged writing; files end to end."""

import json
import re

import numpy as np
import pytest

from nnfmu.data import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.validate import report as report_module
from nnfmu.validate.compare import compare
from nnfmu.validate.files import validate_files
from nnfmu.validate.metrics import DEFINITIONS
from nnfmu.validate.report import write_report

HOSTILE = '<script>alert("x")</script>$\\frac{'
DT = 0.005
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def signals(n: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) * DT
    return t, 800.0 * np.sin(2 * np.pi * 1.5 * t) + 150.0 * np.sin(2 * np.pi * 9.0 * t)


def comparisons():
    t, y = signals()
    reference = Measurement(
        time=t,
        channels={"axial_force": y, HOSTILE: y, "flat": np.zeros_like(y)},
        units={"axial_force": "N", HOSTILE: "N.m", "flat": "m"},
        source="ref",
    )
    result = Measurement(
        time=t,
        channels={"axial_force": 1.1 * y, HOSTILE: y + 5.0, "flat": np.zeros_like(y)},
        units=dict(reference.units),
        source="result",
    )
    return compare(result, reference, ["axial_force", HOSTILE, "flat"])


def test_report_writes_index_summary_and_pngs(tmp_path):
    index = write_report(comparisons(), tmp_path / "report", "Front LCA <bushing>", {"drive file": "belgian & block"})
    out = index.parent
    summary = json.loads((out / "summary.json").read_text())
    assert summary["definitions"] == DEFINITIONS
    assert [c["name"] for c in summary["channels"]] == ["axial_force", HOSTILE, "flat"]
    force = summary["channels"][0]
    assert force["unit"] == "N" and force["basquin_slope"] == 5.0
    assert force["metrics"]["rms_ratio"] == pytest.approx(1.1)
    assert force["metrics"]["pseudo_damage_ratio"] == pytest.approx(1.1**5)
    assert summary["channels"][1]["metrics"]["mean_shift"] == pytest.approx(5.0)
    assert summary["channels"][2]["metrics"]["nrmse"] is None  # 0/0 written as null, not NaN
    html = index.read_text()
    for channel in summary["channels"]:
        assert set(channel["plots"]) == {"time", "psd", "rainflow"}
        for name in channel["plots"].values():
            assert re.fullmatch(r"[A-Za-z0-9_-]+\.png", name)
            assert (out / name).read_bytes().startswith(PNG_MAGIC)
            assert f'src="{name}"' in html
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [n for c in summary["channels"] for n in c["plots"].values()] + ["index.html", "summary.json"]
    )


def test_html_escapes_hostile_names_and_context(tmp_path):
    index = write_report(comparisons(), tmp_path, "Front LCA <bushing>", {"drive <file>": "belgian & block"})
    html = index.read_text()
    assert "<script>" not in html
    assert "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt;" in html
    assert "Front LCA &lt;bushing&gt;" in html
    assert "drive &lt;file&gt;" in html and "belgian &amp; block" in html


@pytest.mark.slow
def test_failure_while_plotting_leaves_the_earlier_report_untouched(tmp_path, monkeypatch):
    out = tmp_path / "report"
    write_report(comparisons(), out, "first", {})
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    calls = []

    def plot_then_fail(c, folder, stem):
        calls.append(stem)
        if len(calls) == 2:
            raise RuntimeError("disk full")
        return original(c, folder, stem)

    original = report_module.plot_channel
    monkeypatch.setattr(report_module, "plot_channel", plot_then_fail)
    with pytest.raises(RuntimeError, match="disk full"):
        write_report(comparisons(), out, "second", {})
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # no staging folder left, nothing replaced


def write_csv(path, header, columns):
    rows = "\n".join(",".join(repr(float(v)) for v in row) for row in np.column_stack(columns))
    path.write_text(header + "\n" + rows + "\n")


def test_validate_files_from_csv_converts_units_and_reports(tmp_path):
    t, y = signals()
    x = 1e-3 * np.sin(2 * np.pi * 1.5 * t)
    write_csv(
        tmp_path / "ref.csv", "time [s],axial_force [N],axial_displacement [m],flat [m]", [t, y, x, np.zeros_like(y)]
    )
    # kN -> N and mm -> m on loading
    write_csv(tmp_path / "result.csv", "time [s],axial_displacement [mm],axial_force [kN]", [t, x * 1e3, 1.1 * y / 1e3])
    report = validate_files(tmp_path / "result.csv", tmp_path / "ref.csv", None, tmp_path / "out")
    # default channels: those both files recorded, not the velocity/acceleration the loader derived
    force, displacement = report.comparisons
    assert (force.name, force.unit) == ("axial_force", "N")
    assert (displacement.name, displacement.unit) == ("axial_displacement", "m")
    assert force.metrics.peak_ratio == pytest.approx(1.1, rel=1e-9)
    assert displacement.metrics.nrmse < 1e-12
    summary = json.loads(report.summary_json.read_text())
    assert summary["context"]["reference"].endswith("ref.csv")
    assert report.index_html.is_file()
    with pytest.raises(DataError, match=r"result\.csv: no channel 'flat'"):
        validate_files(tmp_path / "result.csv", tmp_path / "ref.csv", ["flat"], tmp_path / "out2")
    assert not (tmp_path / "out2").exists()
