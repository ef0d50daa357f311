"""The stabilised bushing ports' elements fitted to the coupled component: the incremental least-squares fit recovers
a linear spring-damper exactly, refuses what is no passive element, and names every element's ports."""

from __future__ import annotations

import numpy as np
import onnx
import pytest

from nnfmu.component import Component, Port
from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.export.graph import GraphBuilder
from nnfmu.reference_stimulus import ReferenceStimulus
from nnfmu.workflows.roadtest.stabilisers import bushing_stabilisers, incremental_element

T = 1e-3
ELEMENTS = {"radial": (7.0e6, 3.0e3), "conical_rotation": (5.0e3, 12.0)}  # (stiffness, damping) per channel


def _motion(n: int, seed: int, scale: float) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    rate = np.cumsum(rng.normal(size=n)) * scale
    return np.cumsum(rate) * T, rate


def test_a_linear_spring_damper_with_a_preload_is_recovered_exactly() -> None:
    x, v = _motion(400, 0, 1e-4)
    assert incremental_element(x, v, 250.0 + 2.0e6 * x + 900.0 * v) == pytest.approx((2.0e6, 900.0), rel=1e-9)


@pytest.mark.parametrize(
    ("length", "stiffness", "damping", "moving"),
    [(400, -2.0e6, 900.0, True), (400, 2.0e6, -900.0, True), (10, 2.0e6, 900.0, True), (400, 2.0e6, 900.0, False)],
)
def test_what_is_no_passive_element_fits_none(length: int, stiffness: float, damping: float, moving: bool) -> None:
    x, v = _motion(length, 1, 1e-4)
    if not moving:
        x, v = np.full(length, 1e-3), np.zeros(length)
    assert incremental_element(x, v, stiffness * x + damping * v) is None


def _linear_bushing(with_stimulus: bool) -> onnx.ModelProto:
    """A stateless step graph of two bushing channels, force = k x + c v, with a reference stimulus if asked."""
    graph = GraphBuilder()
    inputs, outputs, ports_in, ports_out = [], [], [], []
    for key, (stiffness, damping) in ELEMENTS.items():
        channel = BUSHING_CHANNELS[key]
        force = graph.node(
            "Add",
            [
                graph.node("Mul", [channel.position, graph.constant(f"{key}_k", np.array([stiffness]))], f"{key}_kx"),
                graph.node("Mul", [channel.rate, graph.constant(f"{key}_c", np.array([damping]))], f"{key}_cv"),
            ],
            f"{key}_sum",
        )
        graph.output(force, channel.force)
        inputs += [(channel.position, 1), (channel.rate, 1)]
        outputs.append((channel.force, 1))
        ports_in += [Port(channel.position, channel.position_unit, ""), Port(channel.rate, channel.rate_unit, "")]
        ports_out.append(Port(channel.force, channel.force_unit, ""))
    model = graph.model("linear_bushing", "linear bushing channels", inputs, outputs)
    Component(name="linear_bushing", inputs=ports_in, outputs=ports_out, sample_period=T).attach_to(model)
    if with_stimulus:
        motions = {key: _motion(500, seed, 1e-4 if key == "radial" else 1e-2) for seed, key in enumerate(ELEMENTS)}
        ReferenceStimulus(
            source="test motion",
            inputs={
                name: tuple(values)
                for key, (x, v) in motions.items()
                for name, values in ((BUSHING_CHANNELS[key].position, x), (BUSHING_CHANNELS[key].rate, v))
            },
        ).attach_to(model)
    return model


def test_every_element_gets_the_channels_the_graph_computes() -> None:
    fitted = bushing_stabilisers(_linear_bushing(True), ["bushing_fl_front", "bushing_fr_rear"])
    assert set(fitted) == {
        f"{element}_{BUSHING_CHANNELS[key].force}"
        for element in ("bushing_fl_front", "bushing_fr_rear")
        for key in ELEMENTS
    }
    for element in ("bushing_fl_front", "bushing_fr_rear"):
        for key, values in ELEMENTS.items():
            assert fitted[f"{element}_{BUSHING_CHANNELS[key].force}"] == pytest.approx(values, rel=1e-9)


def test_a_graph_without_a_stimulus_keeps_the_parameter_files_elements() -> None:
    assert bushing_stabilisers(_linear_bushing(False), ["bushing_fl_front"]) == {}
