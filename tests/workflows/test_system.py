"""`VirtualSystem`: a quarter car with linear damper FMUs read from its SSD, each element's description and step graph
read once from its FMU, swapped and re-parametrised in memory, co-simulated in memory as a written and reopened
system is, written as SSD and SSP."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest

import nnfmu.workflows.system as system_module
from nnfmu.component import Component
from nnfmu.cosim import CosimSettings, DriveBinding, SspError, cosimulate, open_system
from nnfmu.vehicle import DriveSettings, generate_drive
from nnfmu.workflows.campaign.quarter_car import build_quarter_car_system
from nnfmu.workflows.system import VirtualSystem, VirtualSystemError
from nnfmu.workflows.vehicle_binding import vehicle_binding

SETTINGS = CosimSettings(step=1e-3)


@pytest.fixture(scope="module")
def car(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The campaigns' quarter car: vehicle, a 2400 and a 3600 N.s/m damper FMU, the system with the first."""
    return build_quarter_car_system(tmp_path_factory.mktemp("car"), {"soft": 2400.0, "firm": 3600.0})


@pytest.fixture(scope="module")
def drive():
    return generate_drive(DriveSettings(duration=0.3, seed=1))


def test_elements_their_fmus_descriptions_and_step_graphs_come_from_the_fmus(car) -> None:
    with VirtualSystem.open(car["system"]) as system:
        assert system.elements == ["vehicle", "damper"]
        assert system.fmu("damper") == car["soft"].resolve() and system.fmu("damper").is_absolute()
        assert system.parameters("damper") == {"filter_cutoff": 0.0}
        written = onnx.load(car["soft"].with_suffix(".onnx"))
        assert system.component("damper") == Component.from_onnx(written)
        assert system.step_graph("damper").graph == written.graph
        with pytest.raises(SspError, match="no element 'strut'"):
            system.fmu("strut")


def test_each_fmu_is_read_once_however_often_and_wherever_it_is_asked(car, monkeypatch) -> None:
    reads: list[Path] = []
    real = system_module.read_fmu_graph
    monkeypatch.setattr(system_module, "read_fmu_graph", lambda fmu: reads.append(fmu) or real(fmu))
    with VirtualSystem.open(car["system"]) as system:
        for _ in range(3):
            system.component("damper")
            system.step_graph("damper")
        swapped = system.swap({"damper": car["firm"]})
        swapped.component("damper")
        system.with_parameters({"damper": {"filter_cutoff": 50.0}}).component("damper")
        swapped.swap({"damper": car["soft"]}).step_graph("damper")
    assert reads == [car["soft"].resolve(), car["firm"].resolve()]


def test_a_swap_is_a_new_system_and_cosimulates_in_memory_as_the_written_one_does(car, drive, tmp_path) -> None:
    with VirtualSystem.open(car["system"]) as system:
        firm = system.swap({"damper": car["firm"]}, label="firm")
        assert system.fmu("damper") == car["soft"].resolve()  # the original is unchanged
        assert firm.fmu("damper") == car["firm"].resolve() and firm.name == "quarter car (firm)"
        in_memory = firm.cosimulate(drive, SETTINGS).measurement
        soft = system.cosimulate(drive, SETTINGS).measurement
    ssd = firm.write(tmp_path / "firm")
    with open_system(ssd) as reopened:
        on_disk = cosimulate(reopened, drive, SETTINGS, binding=vehicle_binding(reopened)).measurement
    assert in_memory.names == on_disk.names
    for name in on_disk.names:
        np.testing.assert_array_equal(in_memory[name], on_disk[name], err_msg=name)  # bit for bit
    assert not np.array_equal(in_memory["damper_force"], soft["damper_force"])  # the swap took effect


def test_a_rewired_swap_connects_by_name_like_the_road_test(car) -> None:
    with VirtualSystem.open(car["system"]) as system:
        rewired = system.swap({"damper": car["firm"]}, rewire=True, label="rewired")
        plain = system.swap({"damper": car["firm"]})
    assert sorted(map(str, rewired.structure.connections)) == sorted(map(str, plain.structure.connections))
    assert rewired.parameters("damper") == {"filter_cutoff": 0.0} and rewired.elements == plain.elements


def test_parameters_set_in_memory_change_the_run(car, drive) -> None:
    with VirtualSystem.open(car["system"]) as system:
        filtered = system.with_parameters({"damper": {"filter_cutoff": 20.0}})
        assert system.parameters("damper") == {"filter_cutoff": 0.0}
        assert filtered.parameters("damper") == {"filter_cutoff": 20.0}
        before = system.cosimulate(drive, SETTINGS).measurement["damper_force"]
        after = filtered.cosimulate(drive, SETTINGS).measurement["damper_force"]
        assert not np.array_equal(before, after)
        with pytest.raises(VirtualSystemError, match="no element \\['strut'\\]"):
            system.with_parameters({"strut": {"filter_cutoff": 1.0}})
        with pytest.raises(SspError):
            system.with_parameters({"damper": {"no_such_parameter": 1.0}})


def test_bad_swaps_and_bindings_are_refused_naming_them(car, tmp_path) -> None:
    with VirtualSystem.open(car["system"]) as system:
        with pytest.raises(VirtualSystemError, match="no element \\['strut'\\] to swap"):
            system.swap({"strut": car["firm"]})
        with pytest.raises(VirtualSystemError, match="not found: damper: .*absent.fmu"):
            system.swap({"damper": tmp_path / "absent.fmu"})
        with pytest.raises(SspError, match="no element 'strut'"):
            system.bind(DriveBinding.by_name("strut", ["x"]))
        bound = system.bind(vehicle_binding(system.structure))
        assert bound.drive_binding() == system.drive_binding()


def test_written_ssd_and_ssp_reopen_as_the_same_system(car, drive, tmp_path) -> None:
    with VirtualSystem.open(car["system"]) as system:
        firm = system.swap({"damper": car["firm"]})
        expected = firm.cosimulate(drive, SETTINGS).measurement["damper_force"]
    ssd = firm.write(tmp_path / "folder")
    ssp = firm.write(tmp_path / "car.ssp")
    assert ssd == tmp_path / "folder" / "SystemStructure.ssd" and ssp.is_file()
    assert not list(tmp_path.rglob("*.tmp*"))  # nothing half-written left behind
    for path in (ssd, ssp):
        with VirtualSystem.open(path) as reopened:
            assert reopened.elements == firm.elements
            assert reopened.parameters("damper") == firm.parameters("damper")
            assert reopened.component("damper") == firm.component("damper")
            np.testing.assert_array_equal(reopened.cosimulate(drive, SETTINGS).measurement["damper_force"], expected)


def test_a_system_in_memory_opens_as_itself_and_names_its_file_once_written(car, tmp_path) -> None:
    with VirtualSystem.open(car["system"]) as system:
        assert system.where == car["system"]
        built = VirtualSystem.by_name("car", ("vehicle", car["vehicle"]), {"damper": car["firm"]})
        assert built.where == Path("<car>")
        with VirtualSystem.open(built) as same:
            assert same is built
        written = built.read_from(built.write(tmp_path / "car"))
        assert written.where == tmp_path / "car" / "SystemStructure.ssd" and built.where == Path("<car>")
