"""The own error a network carries (its held-out test split's RMS error), read back torch-free from its description:
per output, merged graphs per part, nothing from a graph that carries none, malformed values refused by name."""

from __future__ import annotations

import math

import pytest

from nnfmu.component import Component, Port
from nnfmu.export.errors import ExportError
from nnfmu.export.own_error import OwnError, carried_own_errors


def _network(output: str, test: dict | None) -> dict:
    """The metadata an nnfmu network carries, as far as its own error goes."""
    return {"feature_spec": {"output": output}} | (
        {"metrics": {"train": {"rms_error": 1.0}, "test": test}} if test else {}
    )


def _component(metadata: dict, outputs: tuple[tuple[str, str], ...] = (("axial_force", "N"),)) -> Component:
    return Component("bushing", [Port("axial_displacement", "m")], [Port(n, u) for n, u in outputs], metadata=metadata)


def test_a_network_carries_its_test_splits_error_in_its_outputs_unit() -> None:
    component = _component(_network("axial_force", {"rms_error": 3.27, "nrmse": 0.0049}))
    own = carried_own_errors(component)
    assert own == {"axial_force": OwnError("axial_force", "N", 3.27, 0.0049)}  # the test split's, not the train's
    assert own["axial_force"].text() == "axial_force 3.27 N RMS (NRMSE 0.49 %)"


def test_a_merged_graph_keeps_each_parts_own_error() -> None:
    parts = [
        {"name": "force", "metadata": _network("axial_force", {"rms_error": 3.0, "nrmse": 0.01})},
        {"name": "torque", "metadata": _network("axial_torque", {"rms_error": 0.1, "nrmse": 0.02})},
        {"name": "older", "metadata": _network("conical_torque", None)},  # an older nnfmu's: left out
    ]
    outputs = (("axial_force", "N"), ("axial_torque", "N.m"), ("conical_torque", "N.m"))
    own = carried_own_errors(_component({"merged_from": parts}, outputs))
    assert own == {
        "axial_force": OwnError("axial_force", "N", 3.0, 0.01),
        "axial_torque": OwnError("axial_torque", "N.m", 0.1, 0.02),
    }


@pytest.mark.parametrize(
    "metadata",
    [
        {},  # a graph from another tool
        _network("axial_force", None),
        _network("axial_force", {"nrmse": 0.01}),  # an older nnfmu's metrics, without the RMS error
        _network("radial_force", {"rms_error": 1.0, "nrmse": 0.01}),  # not this component's output
    ],
)
def test_a_graph_that_carries_none_gives_none(metadata: dict) -> None:
    assert carried_own_errors(_component(metadata)) == {}


@pytest.mark.parametrize("value", [-1.0, math.nan, math.inf, True, "3 N", None])
def test_a_malformed_own_error_is_refused_naming_output_and_value(value: object) -> None:
    component = _component(_network("axial_force", {"rms_error": value, "nrmse": 0.01}))
    with pytest.raises(
        ExportError, match=rf"'bushing': the test split's rms_error of output 'axial_force' is {value!r}"
    ):
        carried_own_errors(component)
