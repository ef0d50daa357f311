"""The port-derivative naming rule: `X_per_Y` counts only beside its flag `X_per_Y_given`."""

from __future__ import annotations

from nnfmu.cosim.port_derivatives import derivative_inputs


def test_pairs_with_their_flags() -> None:
    names = ["f_per_x", "f_per_x_given", "f_per_v", "f", "actuator_per_post"]
    assert derivative_inputs(names) == {"f_per_x", "f_per_x_given"}


def test_nothing_without_flags() -> None:
    assert derivative_inputs(["force_per_displacement", "force"]) == set()
