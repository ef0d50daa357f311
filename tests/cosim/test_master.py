"""The fmpy co-simulation master on a hand-made quarter car + linear damper, against the exact coupled solution.

The reference closes the same damper inside the matrix and is discretised exactly with the same held drive inputs,
so the differences measured here are the coupling errors alone: first order in the step for plain Gauss-Seidel and
Jacobi, second order for linear extrapolation and for the iterated (strongly coupled) step.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import onnx
import pytest
from cosim_system_helpers import (
    BASIC,
    NO_FILTER,
    damper_graph,
    drive,
    peak_error,
    plant_step_graph,
    quarter_cars,
    reference,
)

from nnfmu.cosim.drive_inputs import DriveInputError
from nnfmu.cosim.master import CosimError, CosimSettings, cosimulate, step_count
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.data import Measurement
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions

DURATION = 2.0  # [s]
DRIVE = drive(DURATION, 0.5e-3)


def _error(systems: dict[float, Path], h: float, settings: CosimSettings) -> float:
    with open_system(systems[h]) as system:
        result = cosimulate(system, DRIVE, settings)
    assert result.unconverged_steps == 0
    return peak_error(result.measurement, reference(DURATION, h, mean_hold=not settings.plain))


@pytest.fixture(scope="module")
def errors(systems: dict[float, Path]) -> dict[str, list[float]]:
    """Relative peak error of the damper velocity for each scheme at 2, 1 and 0.5 ms."""
    schemes = {
        "gauss-seidel": BASIC,
        "jacobi": BASIC | {"scheme": "jacobi"},
        "linear": BASIC | {"extrapolation": "linear"},
        "iterative": BASIC | {"iterations": 30, "tolerance": 1e-12},
    }
    return {
        name: [_error(systems, h, CosimSettings(step=h, **kw)) for h in (2e-3, 1e-3, 0.5e-3)]
        for name, kw in schemes.items()
    }


@pytest.mark.slow
def test_gauss_seidel_and_jacobi_converge_to_first_order(errors: dict[str, list[float]]) -> None:
    for name in ("gauss-seidel", "jacobi"):
        e = errors[name]
        ratios = [e[0] / e[1], e[1] / e[2]]
        assert all(1.8 < r < 2.2 for r in ratios), f"{name}: errors {e} do not halve with the step"
    assert all(j > 2 * g for j, g in zip(errors["jacobi"], errors["gauss-seidel"]))  # Jacobi lags one step more


def test_extrapolated_and_iterated_coupling_are_second_order(errors: dict[str, list[float]]) -> None:
    for name in ("linear", "iterative"):
        e = errors[name]
        assert all(3.5 < r < 4.5 for r in (e[0] / e[1], e[1] / e[2])), f"{name}: errors {e} are not second order"


def test_iterative_coupling_is_ten_times_better_than_gauss_seidel_at_1ms(errors: dict[str, list[float]]) -> None:
    assert errors["iterative"][1] * 10 < errors["gauss-seidel"][1]


@pytest.mark.slow
def test_jacobi_iterations_reach_the_same_fixed_point(systems: dict[float, Path]) -> None:
    gauss_seidel = _error(systems, 1e-3, CosimSettings(step=1e-3, iterations=30, tolerance=1e-12, **BASIC))
    jacobi = _error(
        systems, 1e-3, CosimSettings(step=1e-3, iterations=60, tolerance=1e-12, **BASIC | {"scheme": "jacobi"})
    )
    assert jacobi == pytest.approx(gauss_seidel, rel=1e-6)


def test_steps_are_counted_in_integers_and_labelled_with_their_time(systems: dict[float, Path]) -> None:
    assert step_count(0.0, 10.0, 1e-3) == 10_000
    assert step_count(0.0, 10.0, 0.1) == 100
    with pytest.raises(CosimError, match="not a whole"):
        step_count(0.0, 10.0005, 1e-3)
    long_drive = drive(10.0, 1e-3)
    seen: list[tuple[int, int]] = []
    with open_system(systems[1e-3]) as system:
        result = cosimulate(
            system,
            long_drive,
            CosimSettings(step=1e-3, stop_time=10.0),
            progress=lambda done, total: seen.append((done, total)),
        )
    time = result.measurement.time
    assert result.steps == 10_000 and len(time) == 10_001
    assert time[-1] == 10.0
    np.testing.assert_array_equal(time, np.arange(10_001) * 1e-3)
    assert seen[-1] == (10_000, 10_000) and len(seen) <= 201


def test_vehicle_inputs_read_their_own_channels_and_derive_the_velocity(systems: dict[float, Path]) -> None:
    no_rate = Measurement(
        time=DRIVE.time,
        channels={"actuator_displacement": DRIVE["actuator_displacement"]},
        units={"actuator_displacement": "m"},
        source="displacement-only drive",
    )
    settings = CosimSettings(step=1e-3)
    with open_system(systems[1e-3]) as system:
        derived = cosimulate(system, no_rate, settings).measurement
        exact = cosimulate(system, DRIVE, settings).measurement
        with pytest.raises(DriveInputError, match=r"'actuator_displacement'.*the drive has: actuator_fl_displacement"):
            cosimulate(
                system,
                Measurement(
                    DRIVE.time,
                    {"actuator_fl_displacement": DRIVE["actuator_displacement"]},
                    {"actuator_fl_displacement": "m"},
                ),
                settings,
            )
    v = exact["damper_velocity"]
    assert np.max(np.abs(derived["damper_velocity"] - v)) < 1e-3 * np.max(np.abs(v))  # Savitzky-Golay rate


def test_bad_settings_are_refused() -> None:
    with pytest.raises(CosimError, match="scheme 'seidel'"):
        CosimSettings(scheme="seidel")
    with pytest.raises(CosimError, match="communication step"):
        CosimSettings(step=0.0)
    with pytest.raises(CosimError, match="iterations"):
        CosimSettings(iterations=-1)


HAND_WRITTEN = """<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription version="1.0" name="hand written"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">
  <ssd:System name="hand written">
    <ssd:Elements>
      <ssd:Component name="shock" source="{damper}">
        <ssd:Connectors>
          <ssd:Connector name="velocity" kind="input"/>
          <ssd:Connector name="force" kind="output"/>
        </ssd:Connectors>
        <ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" name="p">
          <ssv:Parameters><ssv:Parameter name="filter_cutoff"><ssv:Real value="0"/></ssv:Parameter></ssv:Parameters>
        </ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="car" source="{vehicle}">
        <ssd:Connectors>
          <ssd:Connector name="damper_velocity" kind="output"/>
          <ssd:Connector name="damper_force" kind="input"/>
        </ssd:Connectors>
        <ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" name="p">
          <ssv:Parameters><ssv:Parameter name="filter_cutoff"><ssv:Real value="0"/></ssv:Parameter></ssv:Parameters>
        </ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="car" startConnector="damper_velocity" endElement="shock" endConnector="velocity"/>
      <ssd:Connection startElement="shock" startConnector="force" endElement="car" endConnector="damper_force"/>
    </ssd:Connections>
  </ssd:System>
</ssd:SystemStructureDescription>
"""


def test_a_hand_written_ssd_runs_like_the_generated_one(systems: dict[float, Path], tmp_path: Path) -> None:
    generated = systems[1e-3]
    with open_system(generated) as system:
        sources = {e.name: os.path.relpath(system.fmu_path(e), tmp_path) for e in system.elements}
        expected = cosimulate(system, DRIVE, CosimSettings(step=1e-3)).measurement
    ssd = tmp_path / "SystemStructure.ssd"
    ssd.write_text(HAND_WRITTEN.format(damper=sources["damper"], vehicle=sources["vehicle"]), encoding="utf-8")
    with open_system(tmp_path, allow_outside=True) as system:  # a folder holding SystemStructure.ssd, FMUs elsewhere
        result = cosimulate(system, DRIVE, CosimSettings(step=1e-3)).measurement
    np.testing.assert_array_equal(result["damper_velocity"], expected["damper_velocity"])
    np.testing.assert_array_equal(result["shock_force"], expected["damper_force"])


@pytest.mark.slow
def test_fmi3_fmus_co_simulate_like_fmi2(systems: dict[float, Path], tmp_path: Path) -> None:
    """The same system built as FMI 3 FMUs gives the FMI 2 result, iterative coupling (get/set state) included."""
    open_loop, _ = quarter_cars()
    fmus = {}
    for name, model in (("vehicle", plant_step_graph(open_loop, 1e-3, "quarter_car")), ("damper", damper_graph())):
        onnx_path = tmp_path / f"{name}.onnx"
        onnx.save(model, str(onnx_path))
        fmus[name] = build_fmu(onnx_path, BuildOptions(out=tmp_path / f"{name}.fmu", fmi_version=3))
    system3 = connect_by_name(
        "fmi 3",
        ("vehicle", fmus["vehicle"]),
        {"damper": fmus["damper"]},
        tmp_path,
        parameters={"vehicle": NO_FILTER, "damper": NO_FILTER},
    )
    settings = CosimSettings(step=1e-3, iterations=30, tolerance=1e-12)
    with open_system(write_ssd(system3, tmp_path / "SystemStructure.ssd")) as system:
        fmi3 = cosimulate(system, DRIVE, settings).measurement
    with open_system(systems[1e-3]) as system:
        fmi2 = cosimulate(system, DRIVE, settings).measurement
    for name in fmi2.names:
        np.testing.assert_allclose(fmi3[name], fmi2[name], rtol=1e-12, atol=1e-15)
