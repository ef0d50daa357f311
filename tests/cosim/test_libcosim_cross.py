"""The same SSP system in libcosim (a second, independent master) gives fmpy's result for the same coupling scheme.

libcosim's fixed-step algorithm is a Jacobi scheme (every FMU steps on the values transferred after the previous
step), so it is compared with the fmpy master's plain Jacobi; Gauss-Seidel differs from it by far more than the
tolerance, which shows the comparison can fail.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from cosim_system_helpers import LIBCOSIM, build, damper_graph, drive

from nnfmu.cosim.master import CosimError, CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd

pytest.importorskip("libcosimpy.CosimExecution")
from nnfmu.cosim.libcosim_runner import run_libcosim  # noqa: E402

DRIVE = drive(1.0, 0.5e-3)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.slow
@pytest.mark.parametrize("h", [1e-3, 2e-3])
def test_libcosim_equals_fmpy_jacobi(systems: dict[float, Path], h: float) -> None:
    settings = CosimSettings(step=h, **LIBCOSIM)
    libcosim = run_libcosim(systems[h], DRIVE, settings).measurement
    with open_system(systems[h]) as system:
        fmpy = cosimulate(system, DRIVE, settings).measurement
        gauss_seidel = cosimulate(system, DRIVE, CosimSettings(step=h)).measurement
    assert libcosim.names == fmpy.names
    np.testing.assert_array_equal(libcosim.time, fmpy.time)
    for name in fmpy.names:
        assert _relative(libcosim[name], fmpy[name]) <= 1e-6, name
        assert libcosim.units[name] == fmpy.units[name]
    assert _relative(gauss_seidel["damper_velocity"], libcosim["damper_velocity"]) > 1e-3


def test_libcosim_runner_refuses_other_schemes(systems: dict[float, Path]) -> None:
    with pytest.raises(CosimError, match="Jacobi without extrapolation, iteration or refresh"):
        run_libcosim(systems[1e-3], DRIVE, CosimSettings(step=1e-3))
    with pytest.raises(CosimError, match="whole nanoseconds"):
        run_libcosim(systems[1e-3], DRIVE, CosimSettings(step=1.0000005e-3, stop_time=0.2000001, **LIBCOSIM))


@pytest.mark.slow
def test_libcosim_equals_fmpy_with_the_vehicle_packages_quarter_car(tmp_path: Path) -> None:
    """The vehicle package's quarter-car FMU samples every 0.1 ms, so each 2 ms step evaluates 20 samples."""
    vehicle_build = pytest.importorskip("nnfmu.vehicle.fmu.vehicle_fmu")
    vehicle_fmu = vehicle_build.build_vehicle_fmu("quarter-car", tmp_path / "quarter_car.fmu")
    damper_fmu = build(damper_graph(), tmp_path, "damper")
    system = connect_by_name(
        "quarter car",
        ("vehicle", vehicle_fmu),
        {"damper": damper_fmu},
        tmp_path,
        parameters={"damper": {"filter_cutoff": 0.0}},
    )
    ssd = write_ssd(system, tmp_path / "SystemStructure.ssd")
    settings = CosimSettings(step=2e-3, **LIBCOSIM)
    front_left = drive(1.0, 0.5e-3, corner="fl")  # the channels of the post the quarter car stands on
    libcosim = run_libcosim(ssd, front_left, settings).measurement
    with open_system(ssd) as opened:
        fmpy = cosimulate(opened, front_left, settings).measurement
    assert "body_acceleration" in fmpy.names and np.ptp(fmpy["damper_velocity"]) > 0.0
    for name in fmpy.names:
        assert _relative(libcosim[name], fmpy[name]) <= 1e-6, name


def test_libcosim_loads_the_checked_extracted_system_never_the_archive(
    systems: dict[float, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """libcosim would extract an .ssp again without nnfmu's checks (zip-slip): it must get the extracted copy."""
    import zipfile

    from libcosimpy.CosimExecution import CosimExecution

    archive = tmp_path / "system.ssp"
    with open_system(systems[1e-3]) as system, zipfile.ZipFile(archive, "w") as zf:
        inside = replace(system, elements=[replace(e, source=f"resources/{e.name}.fmu") for e in system.elements])
        zf.write(write_ssd(inside, tmp_path / "SystemStructure.ssd"), "SystemStructure.ssd")
        for element in system.elements:
            zf.write(system.fmu_path(element), f"resources/{element.name}.fmu")
    loaded = []
    original = CosimExecution.from_ssp_file.__func__

    def recording(cls, path: str, step_size=None):
        loaded.append(Path(path))
        return original(cls, path, step_size)

    monkeypatch.setattr(CosimExecution, "from_ssp_file", classmethod(recording))
    result = run_libcosim(archive, DRIVE, CosimSettings(step=1e-3, stop_time=0.1, **LIBCOSIM))
    assert result.steps == 100
    assert loaded and loaded[0].name == "SystemStructure.ssd" and loaded[0] != archive
    assert loaded[0].parent.name.startswith("nnfmu-ssp-") and not loaded[0].exists()  # extracted, since removed
