"""Every kind of FMU nnfmu writes passes two independent compliance checks: fmu-manipulation-toolbox's
`fmutool -check` (modelDescription.xml against the FMI XSD, plus the FMI rules the schema cannot express: unique
names and value references, causality/variability/initial combinations, start values, ModelStructure) and fmpy's
`validate_fmu`. Kinds: network FMUs (native FMI 2 and 3, pythonfmu FMI 2 and 3), the merged bushing graph, vehicle
FMUs (quarter car FMI 2, full vehicle FMI 3 and FMI 2 with stabilised ports). A broken description fails both.
"""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import onnx
import pytest
from exported_networks import FORCE, TORQUE, export_network
from fmpy.validation import validate_fmu

from nnfmu.export.merge import merge_step_graphs
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu

pytestmark = pytest.mark.slow

FMUTOOL = "from fmu_manipulation_toolbox.cli.fmutool import fmutool; fmutool()"


@pytest.fixture(scope="module")
def every_kind(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("kinds")
    force = export_network(FORCE, folder / "force.onnx", 7)
    torque = export_network(TORQUE, folder / "torque.onnx", 8)
    merged = folder / "bushing.onnx"
    onnx.save(merge_step_graphs([onnx.load(force), onnx.load(torque)], "bushing", "force and torque"), merged)
    fmus = {
        f"network native FMI {v}": build_fmu(force, BuildOptions(out=folder / f"n{v}.fmu", fmi_version=v))
        for v in (2, 3)
    }
    fmus |= {
        f"network pythonfmu FMI {v}": build_fmu(
            force, BuildOptions(out=folder / f"p{v}.fmu", fmi_version=v, backend="pythonfmu")
        )
        for v in (2, 3)
    }
    fmus["merged bushing FMI 2"] = build_fmu(merged, BuildOptions(out=folder / "bushing.fmu"))
    fmus["quarter car FMI 2"] = build_vehicle_fmu("quarter-car", folder / "qc.fmu", VehicleBuildSettings())
    fmus["full vehicle FMI 3"] = build_vehicle_fmu(
        "full-vehicle", folder / "fv3.fmu", VehicleBuildSettings(fmi_version=3)
    )
    fmus["full vehicle stabilised FMI 2"] = build_vehicle_fmu(
        "full-vehicle",
        folder / "fv2.fmu",
        VehicleBuildSettings(components={"bushing_fl_front": "stabilised", "bushing_fl_rear": "stabilised"}),
    )
    return fmus


def _fmutool_check(fmu: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", FMUTOOL, "-input", str(fmu), "-check"], capture_output=True, text=True, timeout=120
    )


KINDS = [
    "network native FMI 2",
    "network native FMI 3",
    "network pythonfmu FMI 2",
    "network pythonfmu FMI 3",
    "merged bushing FMI 2",
    "quarter car FMI 2",
    "full vehicle FMI 3",
    "full vehicle stabilised FMI 2",
]


@pytest.mark.parametrize("kind", KINDS)
def test_fmu_passes_fmutool_check_and_fmpy_validation(every_kind, kind):
    fmu = every_kind[kind]
    run = _fmutool_check(fmu)
    log = run.stdout + run.stderr
    assert run.returncode == 0, log
    version = "3" if "FMI 3" in kind else "2"
    assert f"compliant with FMI-{version}.0" in log and f"No semantic error against the FMI-{version}" in log, log
    assert validate_fmu(str(fmu)) == []


def test_a_broken_description_fails_both_checks(every_kind, tmp_path):
    source = every_kind["network native FMI 2"]
    broken = tmp_path / "broken.fmu"
    with zipfile.ZipFile(source) as original, zipfile.ZipFile(broken, "w") as out:
        for name in original.namelist():
            content = original.read(name)
            if name == "modelDescription.xml":
                content = content.replace(b'name="axial_velocity"', b'name="axial_displacement"')
            out.writestr(name, content)
    run = _fmutool_check(broken)
    assert run.returncode != 0 and "axial_displacement' is used by several variables" in run.stdout + run.stderr
    assert any("axial_displacement" in problem for problem in validate_fmu(str(broken)))
