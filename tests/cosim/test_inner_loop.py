"""The master's compiled inner loop against its Python loop: the same numbers bit for bit, the same errors.

Two quarter cars: the vehicle package's (interpolates its inputs, feedthrough at communication points: slopes and the
refresh) and the hand-made sampled one (holds its inputs: the mean of t_n and the estimate), each with a linear damper
FMU, under every one-pass scheme the C loop runs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest
from cosim_system_helpers import build, drive, write_system

from nnfmu.cosim.inner_loop import library
from nnfmu.cosim.master import CosimError, CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu

pytestmark = pytest.mark.skipif(library() is None, reason="no host C compiler for the compiled loop")

H = 1e-3  # [s]
DRIVE = drive(0.5, 0.5e-3, corner="fl")
SCHEMES = [
    {},
    {"scheme": "jacobi"},
    {"refresh": False},
    {"order": "components-first"},
    {"scheme": "jacobi", "refresh": False, "order": "components-first"},
]


def interpolating_system(folder: Path, damping: float) -> Path:
    """The vehicle package's quarter car (fl corner) with a linear damper FMU of `damping` [N.s/m]."""
    folder.mkdir(parents=True, exist_ok=True)
    onnx.save(linear_damper_graph(damping), folder / "damper.onnx")
    damper = build_fmu(folder / "damper.onnx", BuildOptions(out=folder / "damper.fmu"))
    vehicle = build_vehicle_fmu("quarter-car", folder / "car.fmu", VehicleBuildSettings(sample_period=H))
    return write_ssd(
        connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper}, folder), folder / "system.ssd"
    )


@pytest.fixture(scope="module")
def interpolating(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return interpolating_system(tmp_path_factory.mktemp("interpolating"), 2400.0)


@pytest.fixture(scope="module")
def sampled(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("sampled")
    return write_system(folder / "system", H, build(linear_damper_graph(2400.0), folder / "components", "damper"))


def run(ssd: Path, loop: str, **settings: object):
    with open_system(ssd) as system:
        return cosimulate(
            system,
            DRIVE if "interpolating" in str(ssd) else drive(0.5, 0.5e-3),
            CosimSettings(step=H, inner_loop=loop, **settings),
        )


@pytest.mark.slow
@pytest.mark.parametrize("settings", SCHEMES, ids=lambda s: ",".join(f"{k}={v}" for k, v in s.items()) or "default")
@pytest.mark.parametrize("which", ["interpolating", "sampled"])
def test_the_compiled_loop_gives_the_python_loops_numbers(request, which: str, settings: dict) -> None:
    ssd = request.getfixturevalue(which)
    python, compiled = run(ssd, "python", **settings), run(ssd, "c", **settings)
    assert (python.measurement.notes["inner_loop"], compiled.measurement.notes["inner_loop"]) == ("Python", "C")
    assert python.measurement.names == compiled.measurement.names
    for name in python.measurement.names:
        assert np.array_equal(python.measurement[name], compiled.measurement[name]), name
    assert np.ptp(compiled.measurement["damper_force"]) > 10.0  # the damper did work: the comparison means something
    assert (compiled.steps, compiled.passes) == (python.steps, python.passes)


def test_auto_falls_back_to_python_where_the_c_loop_does_not_apply(interpolating: Path) -> None:
    assert run(interpolating, "auto").measurement.notes["inner_loop"] == "C"
    plain = {"extrapolation": "none", "order": "components-first"}
    assert run(interpolating, "auto", **plain).measurement.notes["inner_loop"] == "Python"
    assert run(interpolating, "auto", iterations=2).measurement.notes["inner_loop"] == "Python"
    with pytest.raises(CosimError, match="inner_loop 'c' needs a one-pass scheme"):
        run(interpolating, "c", iterations=2)
    with pytest.raises(CosimError, match="inner_loop 'fortran' is not one of auto, c, python"):
        CosimSettings(inner_loop="fortran")


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_a_diverging_coupling_is_reported_the_same_by_both_loops(tmp_path: Path) -> None:
    """1e7 N.s/m on a 1 ms explicit exchange grows without bound until a rate overflows; both loops name the damper's
    output as the source, at the same step."""
    ssd = interpolating_system(tmp_path / "interpolating", 1.0e7)
    messages = []
    for loop in ("python", "c"):
        with pytest.raises(CosimError) as raised:
            run(ssd, loop)
        messages.append(str(raised.value))
    assert messages[0] == messages[1]
    assert "the coupling diverged: damper (damper.fmu) output force went from" in messages[0]
