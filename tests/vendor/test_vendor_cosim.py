"""`nnfmu cosim` on a vehicle it did not build: the vendor quarter car (tests/vendor/quarter_car.c) with Modelica
unit spellings, inputs held over the step, coupled to an nnfmu damper FMU."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner
from vendor_system import DAMPER, VEHICLE, road, write_vendor_system

from nnfmu.cli import app
from nnfmu.cosim.master import CosimSettings, CosimWarning, cosimulate
from nnfmu.cosim.ssp import Connection, SspError, open_system
from nnfmu.cosim.step_study import study_step
from nnfmu.cosim.units import UnitError
from nnfmu.data import load_measurement
from nnfmu.workflows.cosim import run_cosim

K_T, K_S, M_U = 200e3, 20e3, 40.0  # the vendor car's tyre and spring rates [N/m], unsprung mass [kg]


def test_modelica_units_are_converted_to_si_and_the_result_saves(vendor: tuple[Path, Path], tmp_path: Path) -> None:
    ssd, drive = vendor
    with pytest.warns(CosimWarning):
        result = run_cosim(ssd, drive, CosimSettings(step=1e-3), tmp_path / "out.csv")
    m = load_measurement(tmp_path / "out.csv")  # reads back: every unit SI
    assert m.units["a_body"] == "m/s^2" and m.units["z_body"] == "m" and m.units["F_tyre"] == "N"
    r = result.measurement
    # the wheel's equation of motion at each communication point, F_tyre [kN] -> N and a_spindle [m/s2]
    balance = M_U * r["a_spindle"] - (K_S * r["x_damper"] + r["damper_force"] - r["F_tyre"])
    assert np.max(np.abs(balance)) < 1e-9 * np.max(np.abs(r["F_tyre"]))
    # z_body [mm] -> m: body = damper extension + wheel, wheel = road + tyre deflection (zr at t_n)
    zr = road(0.5)["zr"][::10]
    wheel = zr + r["F_tyre"] / K_T
    assert np.max(np.abs(r["z_body"] - (r["x_damper"] + wheel))) < 1e-12
    assert np.max(np.abs(r["z_body"])) > 5e-3  # metres, not millimetres


def test_a_connection_in_mm_per_s_is_converted_and_c_and_python_loops_agree(tmp_path: Path) -> None:
    drive = road(0.3)
    results = {}
    for unit in ("m/s", "mm/s"):
        ssd = write_vendor_system(tmp_path / unit.replace("/", "_"), velocity_unit=unit)
        with open_system(ssd) as system:
            for loop in ("c", "python"):
                with pytest.warns(CosimWarning):
                    results[unit, loop] = cosimulate(system, drive, CosimSettings(step=1e-3, inner_loop=loop))
    reference = results["m/s", "python"].measurement
    for key, result in results.items():
        m = result.measurement
        assert m.units["v_damper"] == "m/s", key
        for name in reference.names:
            scale = np.max(np.abs(reference[name]))
            assert np.max(np.abs(m[name] - reference[name])) <= 1e-12 * scale, (key, name)
    for name in reference.names:  # the C loop converts as the Python loop does, bit for bit
        assert np.array_equal(results["mm/s", "c"].measurement[name], results["mm/s", "python"].measurement[name])


def test_incompatible_units_are_refused_before_the_run_naming_element_port_and_unit(tmp_path: Path) -> None:
    miswired = (Connection(VEHICLE, "x_damper", DAMPER, "velocity"), Connection(DAMPER, "force", VEHICLE, "F_damper"))
    ssd = write_vendor_system(tmp_path, connections=miswired)
    with pytest.raises(
        SspError,
        match=r"connection vehicle\.x_damper -> damper\.velocity: the output is in 'm', the "
        r"input in 'm/s'",
    ):
        with open_system(ssd):
            pass
    good = write_vendor_system(tmp_path / "good")
    forces = replace(road(0.2), units={"zr": "N"})  # a road displacement given in newtons
    with open_system(good) as system:
        with pytest.raises(UnitError, match=r"element 'vehicle', input 'zr' .*the drive is in 'N'.*input in 'm'"):
            cosimulate(system, forces, CosimSettings(step=1e-3))


def test_an_element_holding_its_inputs_is_warned_about_with_what_it_costs(vendor: tuple[Path, Path]) -> None:
    ssd, drive = vendor
    with pytest.warns(CosimWarning, match=r"'vehicle' .*canInterpolateInputs=false.*h\*\|du/dt\|.*F_damper \d"):
        run_cosim(ssd, drive, CosimSettings(step=1e-3))


def test_step_study_estimates_the_error_at_h_close_to_a_fine_runs(vendor: tuple[Path, Path]) -> None:
    ssd, drive_path = vendor
    drive = load_measurement(drive_path)
    h = 2e-3
    with open_system(ssd) as system, pytest.warns(CosimWarning):

        def run(settings: CosimSettings):
            return cosimulate(system, drive, settings)

        study = study_step(system, CosimSettings(step=h), run, target=0.01)
        coarse = run(CosimSettings(step=h)).measurement
        fine = run(CosimSettings(step=h / 32, stop_time=coarse.time[-1])).measurement
    assert not study.refused and len(study.runs) == 3
    for c in study.channels:
        y, truth = coarse[c.name], fine[c.name][::32]
        actual = np.sqrt(np.mean((y - truth) ** 2)) / np.sqrt(np.mean(truth**2))
        assert 0.9 * actual < c.nrmse_h < 1.2 * actual, (c.name, c.nrmse_h, actual)  # seen: 1.03-1.05 x
        assert c.observed and 0.8 < c.order < 1.2, (c.name, c.order)  # inputs held: first order


def test_cli_step_study_prints_a_table_and_writes_json(vendor: tuple[Path, Path], tmp_path: Path) -> None:
    ssd, drive = vendor
    out = tmp_path / "run.csv"
    args = ["cosim", str(ssd), "--drive", str(drive), "-o", str(out), "--step", "2e-3", "--step-study"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    lines = [line for line in result.stdout.splitlines() if not line.startswith("result at")]  # paths: any length
    assert all(len(line) <= 80 for line in lines), lines
    assert any(line.startswith("a_body ") and "%" in line for line in lines)
    assert "warning: element 'vehicle'" in result.stderr
    study = json.loads(out.with_suffix(".json").read_text())
    assert set(study["channels"]) >= {"a_body", "x_damper", "damper_force"}
    assert study["channels"]["a_body"]["nrmse_at_h"] > 0 and study["largest_step_s"] < 2e-3
    assert out.is_file()


def test_libcosim_refuses_an_fmi3_fmu_before_loading_it(tmp_path: Path) -> None:
    import onnx
    from cosim_system_helpers import damper_graph

    from nnfmu.cosim.libcosim_runner import run_libcosim
    from nnfmu.cosim.master import CosimError
    from nnfmu.fmu.build import build_fmu
    from nnfmu.fmu.options import BuildOptions

    onnx_path = tmp_path / "damper3.onnx"
    onnx.save(damper_graph(), str(onnx_path))
    damper3 = build_fmu(onnx_path, BuildOptions(out=tmp_path / "fmi3" / "fmu" / "damper3.fmu", fmi_version=3))
    ssd = write_vendor_system(tmp_path / "fmi3", damper_fmu=damper3)
    settings = CosimSettings(step=1e-3, scheme="jacobi", extrapolation="none", refresh=False)
    with pytest.raises(CosimError, match=r"element 'damper' \(damper3\.fmu\) is an FMI 3\.0 FMU; libcosim runs FMI 2"):
        run_libcosim(ssd, road(0.1), settings)


def test_libcosim_runs_the_vendor_car_with_results_in_si_and_refuses_a_conversion(tmp_path: Path) -> None:
    from nnfmu.cosim.libcosim_runner import run_libcosim
    from nnfmu.cosim.master import CosimError

    settings = CosimSettings(step=1e-3, scheme="jacobi", extrapolation="none", refresh=False)
    ssd = write_vendor_system(tmp_path / "si")
    cross = run_libcosim(ssd, road(0.3), settings).measurement
    with open_system(ssd) as system:  # libcosim's plain scheme estimates nothing: no warning about held inputs
        own = cosimulate(system, road(0.3), settings).measurement
    assert cross.units == own.units and cross.units["z_body"] == "m"
    for name in own.names:
        assert np.max(np.abs(cross[name] - own[name])) <= 1e-12 * np.max(np.abs(own[name])), name
    with pytest.raises(CosimError, match=r"connection vehicle\.v_damper -> damper\.velocity joins 'mm/s'"):
        run_libcosim(write_vendor_system(tmp_path / "mm", velocity_unit="mm/s"), road(0.3), settings)


def test_outputs_without_dependencies_attributes_feed_through(tmp_path: Path) -> None:
    from vendor_fmu import build_vendor_quarter_car

    from nnfmu.cosim.slave import FmuSlave

    for listed in (True, False):
        with FmuSlave(build_vendor_quarter_car(tmp_path / str(listed), dependencies=listed)) as slave:
            assert slave.feedthrough  # a_body on F_damper listed, or every output on every input (attribute absent)
