"""The FMU description `nnfmu train` writes names the network it trained, not the thesis's layout of its preset."""

from __future__ import annotations

from types import SimpleNamespace

from nnfmu.models.networks import MLP, GRUNet
from nnfmu.models.presets import get_preset
from nnfmu.workflows.train import network_description


def test_description_gives_the_trained_layout() -> None:
    preset = get_preset("damper-hysteresis")
    assert "thesis 2-5-1" in preset.description  # what the old description copied
    text = network_description(preset, SimpleNamespace(network=MLP(4, 12)))
    assert text.endswith(": 4-12-1 tanh MLP") and "thesis" not in text
    assert text.startswith("damper force with hysteresis")
    assert network_description(preset, SimpleNamespace(network=GRUNet(3, 8))).endswith(": 3-8-1 GRU")
