"""Where `nnfmu loop vehicle` gets each element's step graph: from its FMU; `--model` only with the same network;
no ONNX found by its file name (beside the FMU); an FMU without a graph reported as not tested, naming the fix."""

from __future__ import annotations

import json
import os
import re
import zipfile
from pathlib import Path

import onnx
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.data.drive_files import read_drive, write_drive
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.fmu.step_graph import GRAPH_MEMBER, graph_digest
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest import build_vehicle, write_system
from nnfmu.workflows.roadtest.lab_car import LabCar, write_lab_car
from nnfmu.workflows.system import VirtualSystem
from nnfmu.workflows.vehicle_loop import VehicleLoopError
from nnfmu.workflows.vehicle_loop.system_files import VirtualCar
from nnfmu.workflows.vehicle_loop.system_files import read_virtual_car as read_car


def read_virtual_car(ssd: Path, graphs: Path, models: dict | None = None, log=print) -> VirtualCar:
    """The virtual car of the system file `ssd`."""
    with VirtualSystem.open(ssd) as system:
        return read_car(system, ssd, graphs, models, log)


@pytest.fixture(scope="module")
def parts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A quarter car's vehicle FMU and a linear damper FMU built from an ONNX kept elsewhere, another network's ONNX,
    and the damper FMU as an older nnfmu (or another tool) wrote it: no step graph inside."""
    folder = tmp_path_factory.mktemp("graphs")
    onnx.save(linear_damper_graph(1500.0, sample_period=1e-3), folder / "hyst.onnx")
    onnx.save(linear_damper_graph(2500.0, sample_period=1e-3), folder / "other.onnx")
    damper = build_fmu(folder / "hyst.onnx", BuildOptions(out=folder / "cars" / "damper.fmu", platforms=("linux64",)))
    bare = folder / "old" / "damper.fmu"
    bare.parent.mkdir()
    with zipfile.ZipFile(damper) as src, zipfile.ZipFile(bare, "w") as out:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'<Tool name="org\.nnfmu\.step-graph">.*?</Tool>', b"", data, flags=re.DOTALL)
            if item.filename != GRAPH_MEMBER:
                out.writestr(item.filename, data)
    vehicle = build_vehicle("quarter-car", folder / "cars", 1e-3)
    return {"folder": folder, "damper": damper, "bare": bare, "vehicle": vehicle}


def _system(parts: dict[str, Path], damper: Path, folder: Path, beside: Path | None = None) -> Path:
    """A quarter-car system in `folder` with a copy of `damper` (and `beside` copied as `damper.onnx` next to it)."""
    (folder / "fmu").mkdir(parents=True)
    copy = folder / "fmu" / "damper.fmu"
    copy.write_bytes(damper.read_bytes())
    if beside is not None:
        (folder / "fmu" / "damper.onnx").write_bytes(beside.read_bytes())
    return write_system("quarter-car", parts["vehicle"], copy, None, folder / "system")


def test_the_graph_comes_from_the_fmu_and_an_onnx_beside_it_is_never_read(parts, tmp_path: Path) -> None:
    own = graph_digest(onnx.load(parts["folder"] / "hyst.onnx"))
    car = read_virtual_car(_system(parts, parts["damper"], tmp_path / "a"), tmp_path / "g1", log=lambda _: None)
    assert car.onnx["damper"] == tmp_path / "g1" / "damper.onnx" and car.graph_notes == ()
    assert graph_digest(onnx.load(car.onnx["damper"])) == own

    said: list[str] = []
    ssd = _system(parts, parts["damper"], tmp_path / "b", beside=parts["folder"] / "other.onnx")
    car = read_virtual_car(ssd, tmp_path / "g2", log=said.append)
    assert graph_digest(onnx.load(car.onnx["damper"])) == own  # not the other network
    assert car.graph_notes == () and said == []
    bare = _system(parts, parts["bare"], tmp_path / "c", beside=parts["folder"] / "hyst.onnx")
    assert read_virtual_car(bare, tmp_path / "g3", log=said.append).onnx["damper"] is None  # not by its name
    assert said == []


def test_a_given_graph_must_be_the_fmus_network(parts, tmp_path: Path) -> None:
    ssd = _system(parts, parts["damper"], tmp_path / "a")
    same = read_virtual_car(ssd, tmp_path / "g", {"damper": parts["folder"] / "hyst.onnx"}, log=lambda _: None)
    assert same.onnx["damper"] == parts["folder"] / "hyst.onnx"
    with pytest.raises(VehicleLoopError, match=r"--model damper=.*other\.onnx: .* is not the network .* refusing"):
        read_virtual_car(ssd, tmp_path / "g", {"damper": parts["folder"] / "other.onnx"}, log=lambda _: None)


def test_a_given_graph_that_is_a_fifo_a_folder_or_missing_is_named_as_such(parts, tmp_path: Path) -> None:
    """`--model damper=FIFO` read "not found" (no hang): the refusal says what the path is."""
    ssd = _system(parts, parts["damper"], tmp_path / "a")
    fifo = tmp_path / "pipe.onnx"
    os.mkfifo(fifo)
    for given, why in (
        (fifo, "is a FIFO, not a regular file"),
        (tmp_path, "is a folder"),
        (tmp_path / "x", "not found"),
    ):
        with pytest.raises(VehicleLoopError, match=rf"element 'damper' {re.escape(str(given))}: {why}"):
            read_virtual_car(ssd, tmp_path / "g", {"damper": given}, log=lambda _: None)


def test_an_fmu_without_a_graph_takes_a_given_one_unverified_said_so(parts, tmp_path: Path) -> None:
    ssd = _system(parts, parts["bare"], tmp_path / "a")
    car = read_virtual_car(ssd, tmp_path / "g", {"damper": parts["folder"] / "other.onnx"}, log=lambda _: None)
    assert car.onnx["damper"] == parts["folder"] / "other.onnx"
    (note,) = car.graph_notes
    assert "records no step graph" in note and "cannot be checked" in note
    garbage = tmp_path / "garbage.onnx"
    garbage.write_bytes(b"not an onnx file")
    for fmu, where in ((parts["bare"], "b"), (parts["damper"], "c")):  # unverified or checked: a clear error
        ssd = _system(parts, fmu, tmp_path / where)
        with pytest.raises(VehicleLoopError, match=r"garbage\.onnx.*cannot read the ONNX model"):
            read_virtual_car(ssd, tmp_path / "g", {"damper": garbage}, log=lambda _: None)


def test_a_component_without_a_graph_is_reported_not_tested_naming_the_fix(parts, tmp_path: Path) -> None:
    ssd = _system(parts, parts["bare"], tmp_path / "a")
    drive = write_drive(generate_drive(DriveSettings(duration=4.001, seed=5)), tmp_path / "drive.csv")
    record = write_lab_car(LabCar(system="quarter-car"), read_drive(drive), tmp_path / "lab.csv")
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["loop", "vehicle", str(record), "--system", str(ssd), "--drive", str(drive), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    written = json.loads((out / "report.json").read_text())
    assert written["summary"].endswith("; NOT TESTED: damper (no step graph)")
    assert written["summary"] in result.output
    (line,) = written["untested_components"]
    assert line.startswith("damper: its effects are not tested: its FMU damper.fmu carries no step graph")
    assert "rebuild the FMU with nnfmu build" in line and "--model damper=ONNX" in line
    assert result.output.strip().splitlines()[-1] == f"warning: {line}"  # the exit message says so last
    assert "damper:gas_force" in written["untestable"]
    assert "Not tested: damper" in (out / "report.html").read_text()
