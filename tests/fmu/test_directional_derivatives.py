"""Directional derivatives of native network FMUs (fmi2GetDirectionalDerivative, fmi3GetDirectionalDerivative):
d(outputs)/d(inputs) at the current inputs and state, generated from the step graph.

Checked against central differences of the FMU's own outputs (the latest sample evaluated again from a saved FMU
state with each input moved by ±eps; gain and output filter on), against torch autograd of the trained network
(features of the exported spec are linear in the current input, so their derivative is exact from two evaluations),
and for the refusals FMI asks for. Tiny random-weight networks exported like trained ones (exported_networks.py).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from exported_networks import FORCE, T, export_network, random_model, signals
from fmpy.fmi1 import FMICallException

from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.native.toolchain import host_target
from nnfmu.fmu.options import BuildOptions
from nnfmu.models.features import Difference, Highpass, Lowpass, LowpassSquare, SmoothSign, Stop, Tap

pytestmark = pytest.mark.slow  # its networks exported and built for both FMI versions, 10 s of fixtures

SEED = 7
N_STEPS = 40
# Every derived feature of the exporter (Relu of the stop operator, Sqrt-free squares, tanh of the smooth sign,
# differences, filters) and a relaxed start: the graph's tangent passes through every operator nnfmu writes.
RICH = replace(
    FORCE,
    taps=(Tap("axial_displacement", (0, 2)), Tap("axial_velocity", (0, 1))),
    derived=(
        SmoothSign("axial_velocity", scale=0.05),
        Lowpass("axial_displacement", tau=0.01),
        LowpassSquare("axial_velocity", tau=0.05),
        Highpass("axial_displacement", tau=0.02),
        Difference("axial_velocity", delay=2),
        Stop("axial_displacement", radius=0.002),
    ),
    relaxed_start=True,
)


def gru_network(path: Path) -> Path:
    """The recurrent option: a random GRU on FORCE, exported as its gate equations (the hidden state in the state)."""
    import torch

    from nnfmu.export import export_onnx
    from nnfmu.models.networks import GRUNet

    model = random_model(FORCE, SEED)
    torch.manual_seed(SEED)
    network = GRUNet(FORCE.n_features, 4)
    with torch.no_grad():
        for p in network.parameters():
            p.mul_(2.0)
    return export_onnx(replace(model, network=network), path, name="gru_net").path


@pytest.fixture(scope="module")
def networks(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("derivative_networks")
    return {
        "force": export_network(FORCE, folder / "force.onnx", SEED),
        "rich": export_network(RICH, folder / "rich.onnx", 3),
        "gru": gru_network(folder / "gru.onnx"),
    }


BUILDS = [("force", 2), ("force", 3), ("rich", 2), ("rich", 3), ("gru", 3)]


@pytest.fixture(scope="module")
def fmus(tmp_path_factory: pytest.TempPathFactory, networks) -> dict[tuple[str, int], Path]:
    """(network, FMI version) -> FMU, this machine's binary only."""
    folder = tmp_path_factory.mktemp("derivative_fmus")
    host = (host_target().name,)
    return {
        (name, fmi): build_fmu(
            networks[name], BuildOptions(out=folder / f"{name}{fmi}.fmu", fmi_version=fmi, platforms=host)
        )
        for name, fmi in BUILDS
    }


def record(spec, n: int) -> np.ndarray:
    """(n, channels) inputs: the held-out-like signals of the tests' networks."""
    channels = signals(spec.channels, n, SEED + 50)
    return np.column_stack([channels[c] for c in spec.channels])


def run_to(slave, inputs: np.ndarray, gain: float = 1.0, cutoff: float = 0.0, h: float = T) -> None:
    """Initialise with inputs[0], gain and filter cut-off [Hz], then one step of h per further row (inputs set before
    each step)."""
    slave.initialize(inputs[0], parameters={"output_gain": gain, "filter_cutoff": cutoff})
    for n in range(1, len(inputs)):
        slave.set_real(slave.inputs, inputs[n])
        slave.do_step((n - 1) * h, h)


def jacobian(slave) -> np.ndarray:
    """(outputs, inputs) from one directional derivative per input (seed 1)."""
    unknowns = slave.value_references(slave.outputs)
    columns = []
    for vr in slave.value_references(slave.inputs):
        columns.append(slave.fmu.getDirectionalDerivative(unknowns, [vr], [1.0]))
    return np.array(columns).T


def central_differences(slave, inputs: np.ndarray, eps: float = 1e-6, h: float = T) -> np.ndarray:
    """(outputs, inputs): the last step taken again from the FMU state before it with each input moved by ±eps."""
    n = len(inputs) - 1
    saved = slave.get_state()
    columns = []
    for j in range(inputs.shape[1]):
        sides = []
        for sign in (1.0, -1.0):
            moved = inputs[n].copy()
            moved[j] += sign * eps * max(1.0, abs(moved[j]))
            slave.set_state(saved)
            slave.set_real(slave.inputs, moved)
            slave.do_step((n - 1) * h, h)
            sides.append((slave.outputs_now(), moved[j]))
        (up, x_up), (down, x_down) = sides
        columns.append((up - down) / (x_up - x_down))
    slave.set_state(saved)
    slave.set_real(slave.inputs, inputs[n])
    slave.do_step((n - 1) * h, h)
    slave.free_state(saved)
    return np.array(columns).T


@pytest.mark.slow
@pytest.mark.parametrize("filtered", [False, True], ids=["unfiltered", "filtered"])
@pytest.mark.parametrize("network, fmi", BUILDS)
def test_derivatives_equal_central_differences_of_the_fmus_outputs(fmus, open_fmu, network, fmi, filtered):
    """With gain 1.7 and, filtered, the 100 Hz output filter: the derivative is that of the FMU's actual output."""
    spec = RICH if network == "rich" else FORCE
    inputs = record(spec, N_STEPS)
    slave = open_fmu(fmus[(network, fmi)])
    run_to(slave, inputs[:-1], gain=1.7, cutoff=100.0 if filtered else 0.0)
    differences = central_differences(slave, inputs)
    derivatives = jacobian(slave)
    assert np.abs(derivatives).max() > 1.0  # the network is in its nonlinear range, not flat
    np.testing.assert_allclose(derivatives, differences, rtol=1e-6, atol=1e-6 * np.abs(derivatives).max())


@pytest.mark.parametrize("network, fmi", BUILDS)
def test_between_samples_the_derivative_is_that_of_the_interpolated_evaluation(fmus, open_fmu, network, fmi):
    """h = 0.3 T, the last step ending between samples without reaching one: the outputs there are the graph on the
    inputs set before the step and the interpolated state, and the derivative is theirs (filter on, gain 1.7)."""
    h = 0.3 * T
    steps = next(n for n in range(N_STEPS, 0, -1) if math.floor((n - 1) * 0.3 + 1e-9) == math.floor(n * 0.3 - 1e-9))
    spec = RICH if network == "rich" else FORCE
    inputs = record(spec, steps + 1)
    slave = open_fmu(fmus[(network, fmi)])
    run_to(slave, inputs[:-1], gain=1.7, cutoff=100.0, h=h)
    differences = central_differences(slave, inputs, h=h)
    derivatives = jacobian(slave)
    assert np.abs(derivatives).max() > 1.0
    np.testing.assert_allclose(derivatives, differences, rtol=1e-6, atol=1e-6 * np.abs(derivatives).max())


@pytest.mark.parametrize("fmi", [2, 3])
def test_derivatives_equal_torch_autograd_of_the_trained_model(fmus, open_fmu, fmi):
    """d force / d inputs at sample n: the target scaler, torch's Jacobian of the network and the feature scaler,
    times the features' derivative in the current inputs (linear: exact from two evaluations); 1e-9 relative."""
    import torch

    model = random_model(FORCE, SEED)
    inputs = record(FORCE, N_STEPS)
    channels = {c: inputs[:, i] for i, c in enumerate(FORCE.channels)}
    features = FORCE.features(channels, T)
    d_features = []
    for j, channel in enumerate(FORCE.channels):
        moved = {c: v.copy() for c, v in channels.items()}
        rows = []
        for delta in (1.0, -1.0):
            moved[channel][-1] = inputs[-1, j] + delta
            rows.append(FORCE.features(moved, T)[-1])
        d_features.append((rows[0] - rows[1]) / 2.0)
        np.testing.assert_allclose((rows[0] + rows[1]) / 2.0, features[-1], rtol=1e-12, atol=1e-12)  # linear
    scaled = torch.tensor(model.feature_scaler.scale(features[-1]), dtype=torch.float64)
    network = torch.autograd.functional.jacobian(model.network, scaled).numpy()[0]
    expected = np.array([network @ (model.feature_scaler.gain * d) for d in d_features]) / model.target_scaler.gain

    slave = open_fmu(fmus[("force", fmi)])
    run_to(slave, inputs)
    np.testing.assert_allclose(slave.outputs_now()[0], model.predict(channels)[-1], rtol=1e-9)
    np.testing.assert_allclose(jacobian(slave)[0], expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("fmi", [2, 3])
def test_initialization_mode_derivative_is_that_of_the_preview(fmus, open_fmu, fmi):
    """Before initialisation ends the outputs preview sample 0 at the inputs set (relaxed start: the state follows
    them too): the derivative is the preview's, and linear in the seed."""
    inputs = record(RICH, 1)[0]
    slave = open_fmu(fmus[("rich", fmi)])
    slave.enter_initialization(0.0)
    slave.set_real(["output_gain", "filter_cutoff"], [1.7, 100.0])
    knowns, unknowns = slave.value_references(slave.inputs), slave.value_references(slave.outputs)
    differences = []
    for j in range(len(inputs)):
        sides = []
        for sign in (1.0, -1.0):
            moved = inputs.copy()
            moved[j] += sign * 1e-6
            slave.set_real(slave.inputs, moved)
            sides.append(slave.outputs_now()[0])
        differences.append((sides[0] - sides[1]) / 2e-6)
    slave.set_real(slave.inputs, inputs)
    for j, vr in enumerate(knowns):
        derivative = slave.fmu.getDirectionalDerivative(unknowns, [vr], [1.0])[0]
        np.testing.assert_allclose(derivative, differences[j], rtol=1e-6, atol=1e-6 * np.abs(differences).max())
    both = slave.fmu.getDirectionalDerivative(unknowns, knowns, [0.5, -2.0])[0]
    np.testing.assert_allclose(both, 0.5 * differences[0] - 2.0 * differences[1], rtol=1e-6)


@pytest.mark.parametrize("fmi", [2, 3])
def test_unknowns_must_be_outputs_and_knowns_inputs(fmus, open_fmu, fmi):
    """A non-output unknown or non-input known is refused with an error naming its value reference."""
    slave = open_fmu(fmus[("force", fmi)])
    run_to(slave, record(FORCE, 3))
    inputs, outputs = slave.value_references(slave.inputs), slave.value_references(slave.outputs)
    gain, flag = slave.value_references(["output_gain", "extrapolating"])
    refused = [
        ([inputs[0]], [inputs[1]], f"unknown with value reference {inputs[0]} is not a real output"),
        ([flag], [inputs[0]], f"unknown with value reference {flag} is not a real output"),
        ([outputs[0]], [outputs[0]], f"known with value reference {outputs[0]} is not an input"),
        ([outputs[0]], [gain], f"known with value reference {gain} is not an input"),
    ]
    for unknowns, knowns, message in refused:
        slave.messages.clear()
        with pytest.raises(FMICallException):
            slave.fmu.getDirectionalDerivative(unknowns, knowns, [1.0])
        assert any(message in text for _, _, text in slave.messages), slave.messages
    assert np.isfinite(slave.fmu.getDirectionalDerivative(outputs, inputs[:1], [1.0])).all()  # still usable


@pytest.mark.parametrize("fmi", [2, 3])
def test_model_description_declares_derivatives(fmus, fmi):
    with zipfile.ZipFile(fmus[("force", fmi)]) as archive:
        root = ET.fromstring(archive.read("modelDescription.xml"))
    flag = "providesDirectionalDerivative" if fmi == 2 else "providesDirectionalDerivatives"
    assert root.find("CoSimulation").get(flag) == "true"
