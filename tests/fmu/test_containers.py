"""A second, independent master for FMI 3: nnfmu FMUs inside fmu-manipulation-toolbox container FMUs.

libcosimpy loads only FMI 2 FMUs, so FMI 3 FMUs were run by fmpy alone. A container FMU (fmu-manipulation-toolbox,
BSD) embeds FMUs and drives them from its own C runtime (`container.so`), which loads FMI 2 and FMI 3 FMUs; fmpy then
only drives the container. Containers can be FMI 2 or FMI 3 on the outside. The container's outputs must equal fmpy's
direct run of the same FMU to 1e-12 of each output's peak (they were bit-identical), also with parameters exposed
through the container and set to values other than the defaults. A container of the other FMI version than the FMU's
cannot expose its Boolean output (`extrapolating`; the toolbox 2.0 logs "type ... is not compatible") and leaves that
port out, which is all it drops.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from exported_networks import FORCE, export_network
from fmpy import read_model_description, simulate_fmu
from fmu_manipulation_toolbox.assembly import Assembly

from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions

STEP = 1e-3
STOP = 0.4
RELATIVE = 1e-12


@pytest.fixture(scope="module")
def network_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    folder = tmp_path_factory.mktemp("containers")
    onnx_path = export_network(FORCE, folder / "force.onnx", 5)
    return {
        v: build_fmu(onnx_path, BuildOptions(out=folder / f"force{v}.fmu", fmi_version=v, platforms=("linux64",)))
        for v in (2, 3)
    }


def _stimulus(fmu: Path) -> np.ndarray:
    names = [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "input"]
    t = np.arange(0.0, STOP + STEP / 2, STEP)
    signal = np.zeros(len(t), dtype=[("time", float), *((n, float) for n in names)])
    signal["time"] = t
    for i, name in enumerate(names):
        signal[name] = (0.004 + 0.01 * i) * np.sin(2 * np.pi * (3 + 4 * i) * t + i)
    return signal


def _container(fmu: Path, folder: Path, outer: int) -> Path:
    """`fmu` alone in a container FMU of FMI version `outer`, its inputs, outputs and parameters exposed."""
    folder.mkdir()
    shutil.copy(fmu, folder / fmu.name)
    description = {"name": "container.fmu", "fmu": [fmu.name], "step_size": STEP, "auto_parameter": True}
    (folder / "container.json").write_text(json.dumps(description))
    Assembly("container.json", fmu_directory=folder).make_fmu(fmi_version=outer)
    return folder / "container.fmu"


@pytest.mark.slow
@pytest.mark.parametrize("inner,outer", [(3, 3), (3, 2), (2, 3), (2, 2)])
def test_container_runtime_reproduces_fmpys_direct_run(network_fmus, tmp_path, inner, outer):
    fmu = network_fmus[inner]
    container = _container(fmu, tmp_path / "container", outer)
    md = read_model_description(str(container))
    assert md.fmiVersion == f"{outer}.0" and md.coSimulation is not None
    prefix = fmu.stem
    exposed = {v.name for v in md.modelVariables}
    assert {"axial_force", f"{prefix}.filter_cutoff", f"{prefix}.output_gain"} <= exposed
    assert ("extrapolating" in exposed) == (outer == inner)  # Booleans cross no FMI version boundary
    signal = _stimulus(fmu)
    for parameters in ({}, {"filter_cutoff": 30.0, "output_gain": 2.5}):
        direct = simulate_fmu(
            str(fmu),
            stop_time=STOP,
            step_size=STEP,
            output_interval=STEP,
            input=signal,
            output=["axial_force"],
            start_values=parameters,
        )
        contained = simulate_fmu(
            str(container),
            stop_time=STOP,
            step_size=STEP,
            output_interval=STEP,
            input=signal,
            output=["axial_force"],
            start_values={f"{prefix}.{k}": v for k, v in parameters.items()},
        )
        np.testing.assert_array_equal(contained["time"], direct["time"])
        peak = np.max(np.abs(direct["axial_force"]))
        assert peak > 1.0  # the network does something over this stimulus
        assert np.max(np.abs(contained["axial_force"] - direct["axial_force"])) <= RELATIVE * peak
    gained = direct["axial_force"]
    plain = simulate_fmu(
        str(fmu), stop_time=STOP, step_size=STEP, output_interval=STEP, input=signal, output=["axial_force"]
    )["axial_force"]
    assert not np.allclose(gained, plain)  # the parameters reached the FMU and changed its outputs
