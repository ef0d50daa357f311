"""The trained network's warning about input-error amplification (issue 31: nnfmu's own default warned about itself).

A network is judged by its gain (sum_i |dy/dx_i| in scaled units) against the record's own gain: a record that
itself rises steeply (a damper's bleed slope) needs a steep network; a network whose large weights cancel on nearly
collinear inputs amplifies errors the record does not, and warns.

`data/damper-hysteresis-default.onnx` is the default network of the default damper record, trained as a user does
(`nnfmu rig damper --out dyno.csv`, `nnfmu train dyno.csv --preset damper-hysteresis --out m.onnx`: force compensated
for the estimated 2 kg of moving mass, hidden size by validation). Its gain is above 10, which warned before the
record's own gain was taken into account."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from nnfmu.data.inertia import compensate_inertia
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.export import read_step_graph
from nnfmu.models.metrics import (
    GAIN_EXCESS,
    GAIN_WARNING,
    data_gain,
    gain_limit,
    input_error_gain,
    network_warning,
)
from nnfmu.models.networks import MLP

DEFAULT = Path(__file__).parent / "data" / "damper-hysteresis-default.onnx"


def _network(hidden: list[list[float]], bias: list[float], out: list[float]) -> MLP:
    network = MLP(len(hidden[0]), len(hidden))
    with torch.no_grad():
        network.hidden.weight.copy_(torch.tensor(hidden, dtype=torch.float64))
        network.hidden.bias.copy_(torch.tensor(bias, dtype=torch.float64))
        network.out.weight.copy_(torch.tensor([out], dtype=torch.float64))
        network.out.bias.zero_()
    return network


def _default_record() -> tuple[MLP, torch.Tensor, torch.Tensor]:
    """The default network and its 70 s dyno record (the force compensated for the 2 kg fixture, as trained), both
    scaled by the network's own scalers."""
    model, _ = read_step_graph(DEFAULT)
    run = simulate_rig("damper", RigOptions())  # the record `nnfmu rig damper` writes
    record = compensate_inertia(run.measurement, 2.0)
    x = model.feature_scaler.scale(model.spec.features(record.channels, record.sample_period))
    y = model.target_scaler.scale(np.asarray(record["force"], dtype=np.float64))
    return model.network, torch.from_numpy(x), torch.from_numpy(y)


def test_the_record_gain_is_a_lower_bound_that_noise_does_not_raise():
    rng = np.random.default_rng(1)
    x = rng.uniform(-1.0, 1.0, (20000, 2))
    assert 0.6 < data_gain(x, 0.8 * x[:, 0]) <= 0.8 + 1e-9
    assert 11.0 < data_gain(x, np.tanh(15.0 * x[:, 1])) <= 15.0  # steep near zero, as a damper's bleed is
    assert data_gain(x, 0.05 * rng.standard_normal(20000)) < 0.05  # noise alone: its standard errors are taken off


def test_a_network_as_steep_as_its_record_does_not_warn_and_one_steeper_does():
    rng = np.random.default_rng(2)
    a = rng.uniform(-1.0, 1.0, 20000)
    x = torch.from_numpy(np.stack([a, a + 0.0005 * rng.standard_normal(20000)], axis=1))  # a and a noisy copy
    y = torch.tanh(15.0 * x[:, 0])  # a record that itself amplifies errors 15 times near zero
    follows = _network([[15.0, 0.0]], [0.0], [1.0])
    assert input_error_gain(follows, x) > GAIN_WARNING  # the old rule warned
    assert network_warning(follows, x, y) is None
    # the same fit plus a unit of weights 60 that cancel on the record (a - copy is noise): it fits noise
    overfit = _network([[15.0, 0.0], [60.0, -60.0]], [0.0, 0.0], [1.0, 0.5])
    assert float((overfit(x)[:, 0] - y).abs().max().detach()) < 0.1
    assert input_error_gain(overfit, x) > GAIN_EXCESS * data_gain(x.numpy(), y.numpy())
    assert "amplifies input errors" in network_warning(overfit, x, y)


def test_large_weights_cancelling_on_collinear_inputs_still_warn():
    network = _network([[12.0, -12.0], [12.0, -12.0]], [0.0, 0.0], [0.5, 0.5])  # tanh(12 (a - b)): gain 24
    a = torch.linspace(-1.0, 1.0, 201, dtype=torch.float64)
    x = torch.stack([a, a + 0.001 * torch.sin(40 * a)], dim=1)  # nearly equal inputs, as a delayed copy is
    y = network(x)[:, 0].detach()
    assert input_error_gain(network, x) > 2 * GAIN_WARNING
    assert "amplifies input errors" in network_warning(network, x, y)


def test_the_default_damper_network_on_its_record_does_not_warn():
    network, x, y = _default_record()
    gain, own = input_error_gain(network, x), data_gain(x.numpy(), y.numpy())
    assert gain > GAIN_WARNING  # what the thesis's plain limit warned about
    assert own > 4.0  # the damper's bleed slope: 6.8 scaled units per scaled unit of velocity
    assert gain < gain_limit(own)
    assert network_warning(network, x, y) is None
