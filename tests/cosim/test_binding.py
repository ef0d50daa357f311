"""The drive binding: the master feeds exactly the inputs a binding names, from the channels it names, and knows
nothing of vehicles (the hand-made quarter car's inputs carry no corner and no actuator convention the master reads)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from cosim_system_helpers import BASIC, drive

from nnfmu.cosim.binding import DriveBinding, bind_free_inputs, free_inputs
from nnfmu.cosim.drive_inputs import DriveInputError
from nnfmu.cosim.master import CosimError, CosimSettings, cosimulate
from nnfmu.cosim.ssp import open_system
from nnfmu.data import Measurement

DRIVE = drive(0.5, 1e-3)
SETTINGS = CosimSettings(step=1e-3, **BASIC)


def _renamed(m: Measurement, prefix: str) -> Measurement:
    """`m` with every channel renamed `prefix + name` (a drive file whose channels are not named after the inputs)."""
    return Measurement(
        m.time, {prefix + n: m[n] for n in m.names}, {prefix + n: m.units[n] for n in m.names}, source=m.source
    )


def test_the_default_binds_the_one_element_with_free_inputs(systems: dict[float, Path]) -> None:
    with open_system(systems[1e-3]) as system:
        binding = bind_free_inputs(system)
        assert binding.element == "vehicle"
        assert set(binding.inputs) == set(DRIVE.names) and binding.channels == binding.inputs
        assert list(free_inputs(system)) == ["vehicle"]


def test_an_explicit_binding_reads_channels_of_other_names_with_identical_results(systems: dict[float, Path]) -> None:
    with open_system(systems[1e-3]) as system:
        default = cosimulate(system, DRIVE, SETTINGS).measurement
        inputs = bind_free_inputs(system).inputs
        binding = DriveBinding("vehicle", inputs, tuple("post_" + n for n in inputs))
        renamed = cosimulate(system, _renamed(DRIVE, "post_"), SETTINGS, binding=binding).measurement
        with pytest.raises(DriveInputError, match="no channel for the bound input"):
            cosimulate(system, DRIVE, SETTINGS, binding=binding)
    for name in default.names:
        np.testing.assert_array_equal(renamed[name], default[name], err_msg=name)


def test_a_binding_that_misses_or_mistakes_inputs_is_refused_naming_them(systems: dict[float, Path]) -> None:
    with open_system(systems[1e-3]) as system:
        full = bind_free_inputs(system)
        partial = DriveBinding.by_name("vehicle", full.inputs[:1])
        with pytest.raises(CosimError, match=rf"'vehicle': input\(s\) {full.inputs[1]} are connected to nothing"):
            cosimulate(system, DRIVE, SETTINGS, binding=partial)
        with pytest.raises(CosimError, match="names element 'car', which the system does not have"):
            cosimulate(system, DRIVE, SETTINGS, binding=dataclasses.replace(full, element="car"))
        connected = system.connections[0]
        wrong = DriveBinding.by_name(connected.end_element, (connected.end_connector,))
        with pytest.raises(CosimError, match=f"bound input\\(s\\) {connected.end_connector} are not free inputs"):
            cosimulate(system, DRIVE, SETTINGS, binding=wrong)


def test_bindings_pair_inputs_and_channels_one_to_one() -> None:
    with pytest.raises(DriveInputError, match="2 inputs but 1 drive channels"):
        DriveBinding("vehicle", ("a", "b"), ("a",))
    with pytest.raises(DriveInputError, match="bound twice"):
        DriveBinding.by_name("vehicle", ("a", "a"))


def test_no_or_several_driven_elements_are_refused_naming_them(systems: dict[float, Path]) -> None:
    with open_system(systems[1e-3]) as system:
        unwired = dataclasses.replace(system, connections=[])
        with pytest.raises(DriveInputError, match="exactly one element; elements with free inputs: vehicle: .*; damp"):
            bind_free_inputs(unwired)
