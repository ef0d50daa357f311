"""Every FMU nnfmu writes carries its step graph (`extra/org.nnfmu/model.onnx`, component description in its
metadata) bound to it by digests in its model description; a reader refuses an altered graph and tells the FMU's
own network from another one."""

from __future__ import annotations

import re
import zipfile
from pathlib import Path

import onnx
import pytest
from fmpy.validation import validate_fmu

from nnfmu.component import Component
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.step_graph import (
    GRAPH_MEMBER,
    StepGraphError,
    check_same_graph,
    extract_fmu_graph,
    read_fmu_graph,
)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["native", "pythonfmu"])
@pytest.mark.parametrize("fmi_version", [2, 3])
def test_the_fmu_carries_its_own_step_graph_and_description(tmp_path: Path, fmi_version: int, backend: str) -> None:
    for period in (1e-3, None):  # a stateless graph has no sampling annotation, but still its step graph
        source = tmp_path / f"damper_{period}.onnx"
        onnx.save(linear_damper_graph(1500.0, sample_period=period), source)
        fmu = build_fmu(
            source,
            BuildOptions(
                out=tmp_path / "cars" / f"d_{period}_{fmi_version}.fmu",
                fmi_version=fmi_version,
                backend=backend,
                name="front damper",
            ),
        )
        assert validate_fmu(str(fmu)) == []
        data, record = read_fmu_graph(fmu)
        assert record.member == GRAPH_MEMBER == "extra/org.nnfmu/model.onnx"
        embedded = onnx.load_from_string(data)
        component = Component.from_onnx(embedded)
        assert component.name == "front damper" and component.sample_period == period  # the FMU's description
        assert [p.name for p in component.inputs] == ["velocity"] and component.outputs[0].unit == "N"
        check_same_graph(source, record, fmu)  # the source file is that network (its own metadata differs)
        assert len(data) < 4096  # a small network's graph: the FMU grows by a few kB at most
        if backend == "pythonfmu":
            with zipfile.ZipFile(fmu) as archive:
                assert archive.read("resources/model.onnx") == data  # the graph it runs is the one it carries
        extracted = tmp_path / "extracted.onnx"
        assert extract_fmu_graph(fmu, extracted) == record and extracted.read_bytes() == data


def test_another_network_and_an_altered_graph_are_refused_naming_the_files(tmp_path: Path) -> None:
    source = tmp_path / "damper.onnx"
    onnx.save(linear_damper_graph(1500.0, sample_period=1e-3), source)
    fmu = build_fmu(source, BuildOptions(out=tmp_path / "damper.fmu", platforms=("linux64",)))
    _, record = read_fmu_graph(fmu)
    other = tmp_path / "other.onnx"
    onnx.save(linear_damper_graph(1600.0, sample_period=1e-3), other)
    with pytest.raises(StepGraphError, match=r"other\.onnx is not the network .*damper\.fmu was built from"):
        check_same_graph(other, record, fmu)

    altered = tmp_path / "altered.fmu"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(altered, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            dst.writestr(item.filename, other.read_bytes() if item.filename == GRAPH_MEMBER else data)
    with pytest.raises(StepGraphError, match=r"altered\.fmu: extra/org\.nnfmu/model\.onnx has sha256 .* altered"):
        read_fmu_graph(altered)


def test_an_fmu_without_a_record_has_no_graph_and_a_missing_graph_is_an_error(tmp_path: Path) -> None:
    source = tmp_path / "damper.onnx"
    onnx.save(linear_damper_graph(1500.0, sample_period=1e-3), source)
    fmu = build_fmu(source, BuildOptions(out=tmp_path / "damper.fmu", platforms=("linux64",)))
    stripped, bare = tmp_path / "stripped.fmu", tmp_path / "bare.fmu"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(stripped, "w") as without, zipfile.ZipFile(bare, "w") as old:
        for item in src.infolist():
            data = src.read(item)
            if item.filename != GRAPH_MEMBER:
                without.writestr(item.filename, data)
                if item.filename == "modelDescription.xml":  # an FMU of another tool or an older nnfmu
                    data = re.sub(rb'<Tool name="org\.nnfmu\.step-graph">.*?</Tool>', b"", data, flags=re.DOTALL)
                old.writestr(item.filename, data)
    with pytest.raises(StepGraphError, match=r"stripped\.fmu: the step graph extra/org\.nnfmu/model\.onnx .* missing"):
        read_fmu_graph(stripped)
    assert read_fmu_graph(bare) is None
    assert extract_fmu_graph(bare, tmp_path / "none.onnx") is None and not (tmp_path / "none.onnx").exists()
