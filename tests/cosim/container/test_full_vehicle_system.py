"""The full vehicle's system FMU (issue 33): nnfmu's compiled engine against its Python master, scheme by scheme.

The road test's full vehicle with truth physics as its parts: the hysteresis damper's truth law in four FMUs (the LCA
bushings linear inside the vehicle FMU), and the road test's nine FMUs (the four LCA bushings' truth laws on the
vehicle's stabilised ports too). Each runs on ISO 8608 road through `cosimulate` and through `cosimulate_compiled`
(the system FMU stepped from C as a plain master steps it: the drive at t_n, its slope over the step, doStep).

The system FMU knows the drive only at t_n and by the slope the master gives, so it takes the drive at the step's end
as u_n + u' h, which can differ from the sample u_{n+1} in the last bit; and both engines read the drive at t_0 + n h,
which lies a rounding off some of the drive's own stamps, so they interpolate there. The bushing loops carry such
last bits: on the generated road (velocities derived) the engines differed by up to 1.9e-12 of an output's peak with
the five FMUs (default scheme, 1 s) and 1.8e-15 with the nine. The drive is therefore moved, each sample by a few
units in the last place, to one whose samples that arithmetic gives back exactly, stamped at t_0 + n h
(`exactly_interpolated`; the actuator velocities derived beforehand as the engines derive them, and moved too). Then
the engines must agree within 1e-12 of every output's peak; measured: bit for bit, every output, every case here.
"""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from nnfmu.cosim.container.build import build_system_fmu
from nnfmu.cosim.container.engine import cosimulate_compiled
from nnfmu.cosim.master import CosimSettings, CosimWarning, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.data import Measurement
from nnfmu.data.derive import derive_rates
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics.components import REFERENCE
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu
from nnfmu.workflows.roadtest.systems import (
    build_truth_fmus,
    build_vehicle,
    bushing_elements,
    damper_elements,
    write_system,
)

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler"),
]

H = 1e-3  # [s] the communication step, the vehicle's sample period and the system FMU's inner step
DURATION = 0.5  # [s]
TOLERANCE = 1e-12  # relative to each output's peak
SCHEMES = [{}, {"scheme": "jacobi"}, {"order": "components-first", "refresh": False}]


def exactly_interpolated(drive: Measurement, step: float) -> Measurement:
    """`drive` with each sample u_{n+1} moved (a few units in the last place of its channel's values) to one that
    u_n + ((u_{n+1} - u_n) / step) * step gives back exactly in float64, the drive a master's slopes hand a system FMU
    bit for bit, and stamped at t_0 + n step as the engines compute their times (so that they interpolate nothing)."""
    channels = {}
    for name in drive.names:
        u = np.array(drive[name], dtype=float)
        for n in range(len(u) - 1):
            for _ in range(8):
                end = u[n] + ((u[n + 1] - u[n]) / step) * step
                if end == u[n + 1]:
                    break
                u[n + 1] = end
            else:
                raise AssertionError(f"{name}: no sample after t = {drive.time[n]} s is reproduced by its slope")
        channels[name] = u
    time = drive.start + np.arange(len(drive.time)) * step  # the engines' own times: they read samples, not between
    return Measurement(time=time, channels=channels, units=dict(drive.units), source=drive.source)


@pytest.fixture(scope="module", autouse=True)
def own_cache(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201 (a generator fixture)
    """The compiled engine's cache of system FMUs in the test's folder, not the user's."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("NNFMU_CACHE", str(tmp_path_factory.mktemp("cache")))
        yield


@pytest.fixture(scope="module")
def drive() -> Measurement:
    road = derive_rates(
        generate_drive(DriveSettings(duration=DURATION + H))
    )  # the velocities as the engines derive them
    moved = exactly_interpolated(road, H)
    for name in road.names:  # the same road: each sample within a few units in the last place of the channel's peak
        peak = float(np.max(np.abs(road[name])))
        np.testing.assert_allclose(moved[name], road[name], rtol=0.0, atol=4 * np.finfo(float).eps * peak)
    return moved


@pytest.fixture(scope="module")
def truth_fmus(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201 (ComponentFmus)
    return build_truth_fmus(tmp_path_factory.mktemp("truth"), H, with_bushing=True)


@pytest.fixture(scope="module")
def dampers_only(tmp_path_factory: pytest.TempPathFactory, truth_fmus) -> Path:  # noqa: ANN001
    """The full vehicle (LCA bushings linear inside) with the damper truth in four FMUs: 5 FMUs."""
    return dampers_system(tmp_path_factory.mktemp("full_vehicle_dampers"), truth_fmus.dampers["truth"])


def dampers_system(folder: Path, damper: Path, fmi: int = 2) -> Path:
    """The full vehicle (LCA bushings linear inside; FMI version `fmi`) with `damper` in all four corners: 5 FMUs."""
    folder.mkdir(parents=True, exist_ok=True)
    settings = VehicleBuildSettings(
        sample_period=H, components={name: REFERENCE for name in bushing_elements("full-vehicle")}, fmi_version=fmi
    )
    vehicle = build_vehicle_fmu("full-vehicle", folder / "car.fmu", settings)
    dampers = {name: damper for name in damper_elements("full-vehicle")}
    return write_ssd(connect_by_name("full vehicle", ("vehicle", vehicle), dampers, folder), folder / "system.ssd")


@pytest.fixture(scope="module")
def road_test_parts(tmp_path_factory: pytest.TempPathFactory, truth_fmus) -> Path:  # noqa: ANN001
    """The road test's full vehicle: the damper and the LCA bushing truth in eight FMUs, 9 FMUs."""
    folder = tmp_path_factory.mktemp("full_vehicle_road_test")
    vehicle = build_vehicle("full-vehicle", folder, H)
    return write_system("full-vehicle", vehicle, truth_fmus.dampers["truth"], truth_fmus.bushing, folder / "system")


def both_engines(ssd: Path, drive: Measurement, settings: CosimSettings) -> tuple[Measurement, Measurement]:
    with open_system(ssd) as system:
        python = cosimulate(system, drive, settings).measurement
    with open_system(ssd) as system:
        compiled = cosimulate_compiled(system, drive, settings).measurement
    return python, compiled


def largest_difference(result: Measurement, reference: Measurement) -> float:
    return max(
        float(np.max(np.abs(result[c] - reference[c])) / max(float(np.max(np.abs(reference[c]))), 1e-300))
        for c in reference.names
    )


@pytest.mark.parametrize("scheme", SCHEMES, ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()) or "default")
def test_the_full_vehicles_system_fmu_gives_the_masters_numbers(dampers_only: Path, drive: Measurement, scheme: dict):
    python, compiled = both_engines(dampers_only, drive, CosimSettings(step=H, stop_time=DURATION, **scheme))
    assert compiled.names == python.names and len(python.names) > 60
    np.testing.assert_array_equal(compiled.time, python.time)
    assert largest_difference(compiled, python) <= TOLERANCE
    assert min(np.ptp(python[f"{name}_force"]) for name in damper_elements("full-vehicle")) > 100.0  # [N] work done


def test_with_the_road_tests_nine_fmus_too(road_test_parts: Path, drive: Measurement):
    """The default scheme (explicit schemes diverge within 30 ms on the stiff bushing truth at 1 ms)."""
    python, compiled = both_engines(road_test_parts, drive, CosimSettings(step=H, stop_time=DURATION))
    assert largest_difference(compiled, python) <= TOLERANCE
    assert np.ptp(python["bushing_fl_front_radial_force"]) > 10.0  # [N] the bushing FMUs carried load


def part_folders(system_fmu: Path) -> set[str]:
    """The parts' folders in a system FMU (resources/fmus/<index>/)."""
    with zipfile.ZipFile(system_fmu) as archive:
        return {name.split("/")[2] for name in archive.namelist() if name.startswith("resources/fmus/")}


def test_parts_of_one_fmu_share_its_folder(road_test_parts: Path, tmp_path: Path):
    """Nine parts, three FMUs (the vehicle, the damper and the bushing truth): three folders, 4.3 MB unpacked here
    against 14 MB with a copy per part; the runs above step them from one library per FMU."""
    with open_system(road_test_parts) as system:
        build_system_fmu(system, tmp_path / "car.fmu", H)
        assert len(system.elements) == 9
    assert len(part_folders(tmp_path / "car.fmu")) == 3


def test_an_fmu_instantiated_once_per_process_gets_a_copy_per_part(truth_fmus, drive: Measurement, tmp_path: Path):  # noqa: ANN001
    """The damper truth declaring canBeInstantiatedOnlyOncePerProcess: each of its four parts loads its own copy,
    and the engines still agree."""
    once = tmp_path / "once" / "damper.fmu"
    once.parent.mkdir()
    with zipfile.ZipFile(truth_fmus.dampers["truth"]) as source, zipfile.ZipFile(once, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b"<CoSimulation", b'<CoSimulation canBeInstantiatedOnlyOncePerProcess="true"', 1)
            target.writestr(item, data)
    ssd = dampers_system(tmp_path / "system", once)
    with open_system(ssd) as system:
        build_system_fmu(system, tmp_path / "car.fmu", H)
    assert len(part_folders(tmp_path / "car.fmu")) == 5
    python, compiled = both_engines(ssd, drive, CosimSettings(step=H, stop_time=DURATION))
    assert largest_difference(compiled, python) <= TOLERANCE


def test_fmi3_parts_share_a_library_too(truth_fmus, drive: Measurement, tmp_path: Path):  # noqa: ANN001
    """The vehicle and the damper truth as FMI 3 FMUs: two folders for five parts, the engines agree."""
    damper = build_fmu(
        truth_fmus.dampers["truth"].with_suffix(".onnx"), BuildOptions(out=tmp_path / "damper3.fmu", fmi_version=3)
    )
    ssd = dampers_system(tmp_path / "system", damper, fmi=3)
    with open_system(ssd) as system:
        build_system_fmu(system, tmp_path / "car.fmu", H)
    assert len(part_folders(tmp_path / "car.fmu")) == 2
    with pytest.warns(CosimWarning, match="'vehicle'.*cannot interpolate its inputs"):  # FMI 3: no input slopes
        python, compiled = both_engines(ssd, drive, CosimSettings(step=H, stop_time=DURATION))
    assert largest_difference(compiled, python) <= TOLERANCE
