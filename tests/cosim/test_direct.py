"""The master's direct FMI calls against fmpy's own calls, and the master's result against a plain step-by-step loop.

`RealBlock` and `Stepper` bypass fmpy's wrappers, so an FMU driven through them must give exactly what it gives when
driven through fmpy (FMI 2 and 3); the master built on them must reproduce, bit for bit, a Gauss-Seidel loop written
here with fmpy's calls; and a failing call must name the instance, the status and what the FMU logged.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from cosim_system_helpers import BASIC, drive, plant_step_graph, quarter_cars

from nnfmu.cosim.direct import FmiStatusError, RealBlock, Stepper
from nnfmu.cosim.drive_inputs import DriveInputs
from nnfmu.cosim.master import CosimError, CosimSettings, cosimulate
from nnfmu.cosim.slave import FmuSlave
from nnfmu.cosim.ssp import open_system
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions

H = 1e-3
DRIVE = drive(0.5, 0.5e-3)
INPUTS = ("actuator_displacement", "actuator_velocity", "damper_force")


@pytest.fixture(scope="module")
def plants(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    """The hand-made quarter car (state, 3 inputs, 4 outputs, sampled at H) as FMI 2 and FMI 3 FMUs."""
    import onnx

    folder = tmp_path_factory.mktemp("direct")
    onnx_path = folder / "quarter_car.onnx"
    onnx.save(plant_step_graph(quarter_cars()[0], H, "quarter_car"), str(onnx_path))
    return {v: build_fmu(onnx_path, BuildOptions(out=folder / f"quarter_car_{v}.fmu", fmi_version=v)) for v in (2, 3)}


def _start(slave: FmuSlave) -> None:
    slave.enter_initialization(0.0)
    slave.set_real(["filter_cutoff"], [0.0])
    slave.exit_initialization()


@pytest.mark.parametrize("version", [2, 3])
def test_direct_calls_drive_an_fmu_exactly_as_fmpys_calls(plants: dict[int, Path], version: int) -> None:
    inputs = np.random.default_rng(version).uniform(-1.0, 1.0, (200, len(INPUTS))) * [0.02, 0.5, 800.0]
    with FmuSlave(plants[version], "fmpy") as reference, FmuSlave(plants[version], "direct") as direct:
        _start(reference)
        _start(direct)
        outputs = [n for n in reference.names("output") if reference.variables[n].type in ("Real", "Float64")]
        setter, getter, stepper = RealBlock(direct, INPUTS), RealBlock(direct, outputs), Stepper(direct)
        for n, row in enumerate(inputs):
            reference.set_real(INPUTS, row)
            reference.do_step(n * H, H)
            setter.values[:] = row
            setter.set()
            stepper.step(n * H, H)
            getter.get()
            np.testing.assert_array_equal(getter.values, reference.get_real(outputs))
        assert np.any(getter.values != 0.0)


def test_a_refused_input_names_instance_function_status_and_logged_message(plants: dict[int, Path]) -> None:
    with FmuSlave(plants[2], "refusing") as slave, FmuSlave(plants[2], "bystander") as other:
        _start(slave)
        _start(other)
        setter = RealBlock(slave, INPUTS)
        setter.values[:] = [0.0, math.nan, 0.0]
        with pytest.raises(
            FmiStatusError,
            match=r"refusing \(quarter_car_2.fmu\): fmi2SetReal\(actuator_displacement, "
            r"actuator_velocity, damper_force\) returned Error: input "
            r"'actuator_velocity' set to nan: refused",
        ) as refused:
            setter.set()
        assert refused.value.status == 3
        assert other.messages == []  # each FMI 2 instance's messages reach its own slave, not the last one made


def test_a_block_refuses_a_buffer_that_does_not_fit(plants: dict[int, Path]) -> None:
    with FmuSlave(plants[2], "buffer") as slave:
        with pytest.raises(ValueError, match="3 Real variables"):
            RealBlock(slave, INPUTS, np.zeros(4))
        with pytest.raises(ValueError, match="contiguous float64"):
            RealBlock(slave, INPUTS, np.zeros(6)[::2])


def _fmpy_gauss_seidel(ssd: Path, stop: float) -> dict[str, np.ndarray]:
    """The plain Gauss-Seidel of `nnfmu.cosim.master` written step by step with fmpy's calls (damper, then car)."""
    with open_system(ssd) as system:
        paths = {e.name: system.fmu_path(e) for e in system.elements}
    with FmuSlave(paths["damper"], "damper") as damper, FmuSlave(paths["vehicle"], "vehicle") as car:
        feed = DriveInputs(DRIVE, ["actuator_displacement", "actuator_velocity"])
        for slave in (damper, car):
            slave.enter_initialization(0.0)
            slave.set_real(["filter_cutoff"], [0.0])
        car.set_real(feed.names, feed.at(0.0))
        for _ in range(2):
            damper.set_real(["velocity"], car.get_real(["damper_velocity"]))
            car.set_real(["damper_force"], damper.get_real(["force"]))
        for slave in (damper, car):
            slave.exit_initialization()
        car_out = [n for n in car.names("output") if car.variables[n].type in ("Real", "Float64")]
        rows = [np.concatenate([car.get_real(car_out), damper.get_real(["force"])])]
        for n in range(round(stop / H)):
            damper.set_real(["velocity"], car.get_real(["damper_velocity"]))
            damper.do_step(n * H, H)
            car.set_real(["damper_force", *feed.names], [*damper.get_real(["force"]), *feed.at(n * H)])
            car.do_step(n * H, H)
            rows.append(np.concatenate([car.get_real(car_out), damper.get_real(["force"])]))
    table = np.array(rows)
    return {name: table[:, j] for j, name in enumerate([*car_out, "damper_force"])}


def test_the_master_reproduces_a_step_by_step_fmpy_loop_bit_for_bit(systems: dict[float, Path]) -> None:
    expected = _fmpy_gauss_seidel(systems[H], 0.5)
    with open_system(systems[H]) as system:
        result = cosimulate(system, DRIVE, CosimSettings(step=H, stop_time=0.5, **BASIC)).measurement
    assert set(result.names) == set(expected)
    for name in result.names:
        np.testing.assert_array_equal(result[name], expected[name], err_msg=name)


def test_a_failing_fmu_stops_the_run_naming_element_and_time(systems: dict[float, Path]) -> None:
    broken = DRIVE.channels | {"actuator_velocity": np.where(DRIVE.time >= 0.25, math.nan, DRIVE["actuator_velocity"])}
    bad = type(DRIVE)(DRIVE.time, broken, DRIVE.units, "drive with a gap")
    with open_system(systems[H]) as system:
        with pytest.raises(
            CosimError,
            match=r"step from t = 0\.25 s: vehicle \(quarter_car.fmu\): fmi2SetReal.*"
            r"returned Error: input 'actuator_velocity' set to nan",
        ):
            cosimulate(system, bad, CosimSettings(step=H, stop_time=0.5, **BASIC))
