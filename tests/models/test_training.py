"""Training: the hand-written LM Jacobian, LM convergence, early stopping, determinism, splits, optimisers, and a
workflow run that writes a verified ONNX file."""

from __future__ import annotations

import re
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np
import onnx
import pytest
import torch
from torch.func import functional_call, jacrev

from nnfmu.component import Component
from nnfmu.data.band import excited_band
from nnfmu.data.measurement import Measurement
from nnfmu.errors import SettingsError
from nnfmu.models import lm as lm_module
from nnfmu.models import train as train_module
from nnfmu.models.features import FeatureSpec, Stop, Tap
from nnfmu.models.lm import LMSettings, fit_lm, mlp_jacobian
from nnfmu.models.networks import MLP
from nnfmu.models.splits import SplitFractions, contiguous_splits
from nnfmu.models.stopping import EarlyStopping
from nnfmu.models.train import Architecture, TrainSettings, train_model
from nnfmu.models.trained import data_hash

T = 0.001
# The lagged damper's force from its velocity now and 4 samples ago: a small spec the search tests train quickly
LAGGED_VELOCITY = FeatureSpec(taps=(Tap("velocity", (0, 4)),), output="force")


def lagged_damper(n: int = 3000, seed: int = 0, lag: float = 0.004) -> Measurement:
    """Digressive asymmetric damper force behind a first-order lag, under smooth random velocity."""
    rng = np.random.default_rng(seed)
    kernel = np.hanning(41)
    v = np.convolve(rng.standard_normal(n + 40), kernel / kernel.sum(), mode="valid")
    v *= 0.5 / np.max(np.abs(v))
    static = np.where(v > 0, 2000 * np.tanh(v / 0.15), 900 * np.tanh(v / 0.2))
    a = -np.expm1(-T / lag)
    force = np.zeros(n)
    state = 0.0
    for k in range(n):
        state += a * (static[k] - state)
        force[k] = state
    return Measurement(
        time=np.arange(n) * T,
        channels={"velocity": v, "displacement": np.cumsum(v) * T, "force": force},
        units={"velocity": "m/s", "displacement": "m", "force": "N"},
        source="synthetic lagged damper",
    )


def teacher_data(n: int, seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Samples of a 1-3-1 tanh net with known weights: an LM fit of a 1-3-1 net can reach it exactly."""
    x = torch.linspace(-1, 1, n, dtype=torch.float64)[:, None]
    torch.manual_seed(seed)
    teacher = MLP(1, 3)
    with torch.no_grad():
        teacher.hidden.weight.copy_(torch.tensor([[2.0], [-1.5], [0.7]]))
        teacher.hidden.bias.copy_(torch.tensor([0.3, -0.2, 0.1]))
        teacher.out.weight.copy_(torch.tensor([[0.8, 0.5, -0.6]]))
        teacher.out.bias.fill_(0.05)
        y = teacher(x)[:, 0]
    return x, y


def test_hand_jacobian_equals_autograd():
    torch.manual_seed(1)
    net = MLP(3, 4)
    x = torch.randn(7, 3, dtype=torch.float64)
    y, jacobian = mlp_jacobian(net, x)
    params = dict(net.named_parameters())
    reference = jacrev(lambda p: functional_call(net, p, (x,))[:, 0])(params)
    expected = torch.cat([reference[name].reshape(7, -1) for name in params], dim=1)
    torch.testing.assert_close(y, net(x)[:, 0], rtol=0, atol=1e-14)
    torch.testing.assert_close(jacobian, expected, rtol=1e-12, atol=1e-14)


def test_lm_decreases_the_loss_and_fits_a_known_function():
    x, y = teacher_data(200, seed=0)
    torch.manual_seed(5)
    net = MLP(1, 3)
    history = fit_lm(net, (x[::2], y[::2]), (x[1::2], y[1::2]), LMSettings(max_epochs=200, patience=50))
    assert all(b < a for a, b in zip(history.train_loss, history.train_loss[1:]))  # LM accepts only improving steps
    assert history.train_loss[0] > 1e-3
    with torch.no_grad():
        assert float(torch.mean((net(x)[:, 0] - y) ** 2)) < 1e-8  # RMS error 1e-4 on a target of range ~0.2


def test_lm_gives_the_same_network_whether_a_spare_core_takes_half_of_each_epoch_or_not(monkeypatch):
    # The second half of the samples' JᵀJ and Jᵀr runs on the lent core or here; the sums are the same either way.
    monkeypatch.setattr(lm_module, "MIN_LENT_JACOBIAN", 0)  # lent however small the half
    x, y = teacher_data(301, seed=2)
    lent = []

    def lend(task):
        lent.append(task)
        with ThreadPoolExecutor(1) as helper:
            done = helper.submit(task)
            done.result()
            return done

    nets = []
    for lender in (None, lend):
        torch.manual_seed(4)
        nets.append(MLP(1, 3))
        fit_lm(nets[-1], (x[::2], y[::2]), (x[1::2], y[1::2]), LMSettings(max_epochs=30, patience=30), lend=lender)
    assert len(lent) == 30
    for a, b in zip(nets[0].parameters(), nets[1].parameters()):
        assert torch.equal(a, b)


def correlated_inputs(n: int, seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    """A velocity-like input, a copy of it shifted by a small lag term (0.99 correlated) and an offset copy (1.0), and
    a target that depends on their small difference: the case LM's input coordinates are for."""
    rng = np.random.default_rng(seed)
    kernel = np.hanning(31)
    v = np.convolve(rng.standard_normal(n + 30), kernel / kernel.sum(), mode="valid")
    v /= np.abs(v).max()
    d = np.diff(v, prepend=v[0]) * 20
    x = np.stack([v, v - 0.05 * d, v + 0.5], axis=1)
    return torch.from_numpy(x), torch.from_numpy(np.tanh(3 * v) + 2 * d + 0.3 * np.tanh(5 * d))


@pytest.mark.parametrize("inputs", ["standardised", "whitened"])
def test_lm_in_other_input_coordinates_starts_from_and_ends_with_the_network_on_raw_inputs(inputs):
    # The weights are carried into the coordinates and back: the first loss is the raw network's, the kept network
    # (on raw inputs) reproduces its recorded validation loss, and only improving steps are taken.
    x, y = correlated_inputs(1000, seed=0)
    train, validation = (x[::2], y[::2]), (x[1::2], y[1::2])
    histories, nets = [], []
    for kind in ("raw", inputs):
        torch.manual_seed(3)
        nets.append(MLP(3, 4))
        histories.append(fit_lm(nets[-1], train, validation, LMSettings(max_epochs=40, patience=40, inputs=kind)))
    raw, other = histories
    assert other.train_loss[0] == pytest.approx(raw.train_loss[0], rel=1e-12)
    assert other.validation_loss[0] == pytest.approx(raw.validation_loss[0], rel=1e-12)
    assert all(b < a for a, b in zip(other.train_loss, other.train_loss[1:]))
    assert other.train_loss[1] != pytest.approx(raw.train_loss[1], rel=1e-6)  # the steps were taken elsewhere
    with torch.no_grad():
        kept = float(torch.mean((nets[1](validation[0])[:, 0] - validation[1]) ** 2))
    assert kept == pytest.approx(other.best_validation_loss, rel=1e-9)


def test_unknown_lm_input_coordinates_are_refused_by_name():
    with pytest.raises(SettingsError, match="'polar'"):
        TrainSettings(lm_inputs="polar")
    with pytest.raises(SettingsError, match="'polar'"):
        LMSettings(inputs="polar")


def test_the_training_settings_carry_the_lm_coordinates_into_the_fit(monkeypatch):
    seen = []
    real = train_module.fit_lm

    def spy(network, train, validation, settings, *args, **kwargs):
        seen.append(settings.inputs)
        return real(network, train, validation, replace(settings, max_epochs=2), *args, **kwargs)

    monkeypatch.setattr(train_module, "fit_lm", spy)
    settings = TrainSettings(restarts=1, max_epochs=2, lm_inputs="whitened")
    result = train_model(lagged_damper(800), LAGGED_VELOCITY, Architecture("mlp", (3,)), settings)
    assert seen == ["whitened"]
    assert result.model.settings["lm_inputs"] == "whitened"  # recorded in the model (its ONNX metadata)


def test_early_stopping_keeps_the_best_epoch():
    net = torch.nn.Linear(1, 1)
    stopper = EarlyStopping(patience=2)
    losses = [5.0, 3.0, 1.0, 2.0, 1.5, 0.5]  # 0.5 comes after patience ran out and is never seen
    stops = []
    for epoch, loss in enumerate(losses):
        with torch.no_grad():
            net.weight.fill_(float(epoch))
        stops.append(stopper.update(epoch, loss, net))
        if stops[-1]:
            break
    assert stops == [False, False, False, False, True]
    assert stopper.best_epoch == 2 and stopper.best_loss == 1.0
    stopper.restore(net)
    assert float(net.weight.detach()) == 2.0


def test_lm_run_ends_on_its_best_validation_epoch():
    # Few noisy training samples and a large net over-fit; the kept weights are those of the best validation epoch.
    rng = np.random.default_rng(0)
    x = torch.linspace(-1, 1, 400, dtype=torch.float64)[:, None]
    y = torch.sin(3 * x[:, 0]) + torch.from_numpy(0.3 * rng.standard_normal(400))
    torch.manual_seed(0)
    net = MLP(1, 12)
    history = fit_lm(net, (x[::20], y[::20]), (x[1::2], y[1::2]), LMSettings(max_epochs=100, patience=5))
    best = int(np.argmin(history.validation_loss))
    assert history.best_epoch == best
    with torch.no_grad():
        kept = float(torch.mean((net(x[1::2])[:, 0] - y[1::2]) ** 2))
    assert kept == pytest.approx(history.validation_loss[best], rel=1e-12)


def test_contiguous_splits():
    s = contiguous_splits(100, SplitFractions(0.7, 0.15, 0.15, blocks=1))
    assert (s.train, s.validation, s.test) == ((slice(0, 70),), (slice(70, 85),), (slice(85, 100),))
    s = contiguous_splits(200, SplitFractions(0.7, 0.15, 0.15, blocks=2))
    assert s.train == (slice(0, 70), slice(100, 170)) and s.test == (slice(85, 100), slice(185, 200))
    assert s.size("validation") == 30 and list(s.index("validation")[[0, -1]]) == [70, 184]
    everything = np.sort(np.concatenate([s.index(name) for name, _ in s.items()]))
    np.testing.assert_array_equal(everything, np.arange(200))
    with pytest.raises(ValueError, match="add up to 1"):
        SplitFractions(0.5, 0.2, 0.2)
    with pytest.raises(ValueError, match="validation split only 1 samples"):
        contiguous_splits(20, SplitFractions(0.9, 0.05, 0.05, blocks=1))


def test_training_is_deterministic_for_a_seed():
    m = lagged_damper(1500)
    spec = LAGGED_VELOCITY
    settings = TrainSettings(max_epochs=15, restarts=2, seed=3)
    first = train_model(m, spec, Architecture("mlp", (3,)), settings)
    second = train_model(m, spec, Architecture("mlp", (3,)), settings)
    other = train_model(m, spec, Architecture("mlp", (3,)), TrainSettings(max_epochs=15, restarts=2, seed=4))
    for a, b in zip(first.model.network.parameters(), second.model.network.parameters()):
        assert torch.equal(a, b)
    assert first.model.metrics == second.model.metrics
    assert any(
        not torch.equal(a, b) for a, b in zip(first.model.network.parameters(), other.model.network.parameters())
    )


@pytest.mark.parametrize("optimizer", ["lm", "adam"])
def test_a_search_gives_the_same_network_however_many_runs_go_side_by_side(monkeypatch, optimizer):
    # Runs are seeded alone and their histories gathered in order: one thread at a time or one per run, the same
    # weights, the same chosen size and the same per-size validation errors.
    m = lagged_damper(1500)
    spec = LAGGED_VELOCITY
    settings = TrainSettings(max_epochs=12, restarts=2, seed=3, optimizer=optimizer)
    results = []
    for threads in (1, 6):
        monkeypatch.setattr(train_module, "parallel_fits", lambda runs, threads=threads: min(runs, threads))
        results.append(train_model(m, spec, Architecture("mlp", (2, 3, 4)), settings))
    one, many = results
    assert [t.validation_mse for t in one.trials] == [t.validation_mse for t in many.trials]
    assert one.model.settings["hidden"] == many.model.settings["hidden"]
    for a, b in zip(one.model.network.parameters(), many.model.network.parameters()):
        assert torch.equal(a, b)


def test_the_largest_networks_start_first(monkeypatch):
    # The longest runs go first, so that no core is left finishing one alone at the end of the search.
    started: list[int] = []
    fit = train_module.fit_network

    def recorded(network, data, settings, seed, on_epoch, **lent):
        started.append(network.hidden.out_features)
        return fit(network, data, settings, seed, on_epoch, **lent)

    monkeypatch.setattr(train_module, "fit_network", recorded)
    monkeypatch.setattr(train_module, "parallel_fits", lambda runs: 1)
    train_model(lagged_damper(1500), LAGGED_VELOCITY, Architecture("mlp", (2, 4, 3)), TrainSettings(max_epochs=2))
    assert started == [4, 4, 4, 3, 3, 3, 2, 2, 2]


def test_an_interrupted_run_stops_the_whole_search(monkeypatch):
    # A stop in one run (Ctrl-C reaching a worker, a failing fit) ends the search with that error at once: the runs
    # still going stop at their next epoch and the ones not started never start.
    started: list[int] = []
    fit = train_module.fit_network

    def interrupted(network, data, settings, seed, on_epoch, **lent):
        started.append(seed)
        if len(started) == 1:
            raise KeyboardInterrupt("stop asked for")
        return fit(network, data, settings, seed, on_epoch, **lent)

    monkeypatch.setattr(train_module, "fit_network", interrupted)
    monkeypatch.setattr(train_module, "parallel_fits", lambda runs: 1)
    m = lagged_damper(1500)
    spec = LAGGED_VELOCITY
    with pytest.raises(KeyboardInterrupt, match="stop asked for"):
        train_model(m, spec, Architecture("mlp", (2, 3)), TrainSettings(max_epochs=5, restarts=3))
    assert len(started) == 1


def test_a_run_failing_while_an_earlier_one_still_runs_ends_the_search(monkeypatch):
    # Two threads: the first run is still going when the second fails. The search ends with that error without
    # waiting for the first to finish its fit, and the runs not yet started do not run to the end.
    started: list[int] = []
    failed = threading.Event()
    fit = train_module.fit_network

    def second_fails(network, data, settings, seed, on_epoch, **lent):
        started.append(seed)
        if len(started) == 2:
            failed.set()
            raise RuntimeError("the second run failed")
        if len(started) == 1:  # a long run: it waits for the failure, then takes 50 ms an epoch
            failed.wait(timeout=30)

            def slow(epoch: int, total: int) -> None:
                time.sleep(0.05)
                on_epoch(epoch, total)

            return fit(network, data, settings, seed, slow, **lent)
        return fit(network, data, settings, seed, on_epoch, **lent)

    monkeypatch.setattr(train_module, "fit_network", second_fails)
    monkeypatch.setattr(train_module, "parallel_fits", lambda runs: 2)
    m = lagged_damper(1500)
    spec = LAGGED_VELOCITY
    with pytest.raises(RuntimeError, match="the second run failed"):
        train_model(m, spec, Architecture("mlp", (2, 3, 4)), TrainSettings(max_epochs=200, patience=200, restarts=2))
    assert len(started) < 6


def test_a_refused_choice_gives_way_to_the_next_best_network_the_check_accepts():
    # The acceptance check (in `nnfmu train`: passivity) sees the search's choice first; refused, the next run by
    # validation error is tried, and the notes say what was refused and why. Refusing all keeps the choice.
    m = lagged_damper(1500)
    spec = LAGGED_VELOCITY
    architecture, settings = Architecture("mlp", (2, 3)), TrainSettings(max_epochs=12, restarts=2, seed=3)
    plain = train_model(m, spec, architecture, settings)
    seen: list[float] = []

    def refuse_the_first(model):
        seen.append(model.metrics["validation"]["mse_scaled"])
        return ["too lively"] if len(seen) == 1 else []

    kept = train_model(m, spec, architecture, settings, accept=refuse_the_first)
    assert len(seen) == 2 and seen[0] == plain.model.metrics["validation"]["mse_scaled"]
    assert kept.model.metrics["validation"]["mse_scaled"] == seen[1] != seen[0]
    assert "refused: too lively" in kept.notes[0] and "kept the best network that passes" in kept.notes[0]
    refused = train_model(m, spec, architecture, settings, accept=lambda model: ["never"])
    assert refused.model.metrics == plain.model.metrics
    assert refused.notes == ["none of the search's 4 networks passes: never; kept its choice"]
    assert refused.warnings[-1] == "never"  # the kept choice carries its refusal


def test_a_stop_the_record_never_slips_is_left_out_and_said():
    # The record moves +-30 um about 100 um: the 5 um stop's play is dragged most of the time, the 80 um one's never
    # (its output is the position less its first value, and would tie the network to where the record starts).
    n = 3000
    t = np.arange(n) * T
    x = 100e-6 + 30e-6 * np.sin(2 * np.pi * 2.0 * t) * np.sin(2 * np.pi * 0.3 * t)
    v = np.gradient(x, T)
    m = Measurement(
        time=t,
        channels={"x": x, "v": v, "force": 1e6 * x + 20.0 * np.tanh(v / 1e-4)},
        units={"x": "m", "v": "m/s", "force": "N"},
        source="synthetic bushing",
    )
    small, large = Stop("x", radius=5e-6), Stop("x", radius=80e-6)
    spec = FeatureSpec(taps=(Tap("x"), Tap("v")), output="force", derived=(small, large), relaxed_start=True)
    quick = (Architecture("mlp", (2,)), TrainSettings(max_epochs=5, restarts=1))
    result = train_model(m, spec, *quick)
    assert [d.name for d in result.model.spec.derived] == [small.name]
    assert result.model.network.hidden.in_features == 3
    assert len(result.notes) == 1 and large.name in result.notes[0] and "0.0%" in result.notes[0]
    assert train_model(m, FeatureSpec(taps=(Tap("x"), Tap("v")), output="force", derived=(small,)), *quick).notes == []


def test_delays_capture_the_lag_a_static_map_cannot():
    m = lagged_damper(4000)
    settings = TrainSettings(max_epochs=60, restarts=2)
    static = train_model(m, FeatureSpec((Tap("velocity"),), "force"), Architecture("mlp", (3,)), settings)
    delayed = train_model(m, FeatureSpec((Tap("velocity", (0, 3, 6)),), "force"), Architecture("mlp", (5,)), settings)
    assert delayed.model.metrics["test"]["nrmse"] < 0.5 * static.model.metrics["test"]["nrmse"]
    assert static.model.metrics["test"]["nrmse"] > 0.02  # the lag is real: a static map misses it


def test_trained_model_carries_context():
    m = lagged_damper(1500)
    spec = FeatureSpec((Tap("velocity"),), "force")
    result = train_model(m, spec, Architecture("mlp", (2, 3)), TrainSettings(max_epochs=10, restarts=1))
    model = result.model
    train, test = result.splits.index("train"), result.splits.index("test")
    assert model.envelope["velocity"] == (m["velocity"][train].min(), m["velocity"][train].max())
    assert model.band == {"velocity": excited_band(m["velocity"], T)} and model.band["velocity"] > 0
    assert model.units == {"velocity": "m/s", "force": "N"}
    assert model.sample_period == pytest.approx(T)
    assert set(model.metrics) == {"train", "validation", "test"}
    assert [t.hidden for t in result.trials] == [2, 3] and model.settings["hidden"] in (2, 3)
    assert model.data_hash == data_hash(m, ["velocity", "force"])
    changed = Measurement(m.time, {**m.channels, "force": m["force"] + 1e-9}, m.units)
    assert data_hash(changed, ["velocity", "force"]) != model.data_hash
    prediction = model.predict({"velocity": m["velocity"]})
    assert model.metrics["test"]["nrmse"] == pytest.approx(
        np.sqrt(np.mean((prediction[test] - m["force"][test]) ** 2)) / np.sqrt(np.mean(m["force"][test] ** 2)),
        rel=1e-9,
    )


@pytest.mark.parametrize("optimizer", ["adam", "lbfgs"])
def test_gradient_optimisers_reduce_validation_error(optimizer):
    m = lagged_damper(1500)
    result = train_model(
        m,
        FeatureSpec((Tap("velocity"),), "force"),
        Architecture("mlp", (3,)),
        TrainSettings(optimizer=optimizer, max_epochs=20, restarts=1),
    )
    assert result.model.settings["optimizer_used"] == optimizer
    assert result.history.best_validation_loss < 0.5 * result.history.validation_loss[0]


def test_gru_trains_and_predicts_sequentially():
    m = lagged_damper(1500)
    settings = TrainSettings(max_epochs=8, restarts=1, chunk_length=200, burn_in=40, learning_rate=0.02)
    result = train_model(m, FeatureSpec((Tap("velocity"),), "force"), Architecture("gru", (4,)), settings)
    assert result.model.settings["optimizer_used"] == "adam"
    assert result.history.best_validation_loss < result.history.validation_loss[0]
    with pytest.raises(ValueError, match="Adam"):
        train_model(
            m, FeatureSpec((Tap("velocity"),), "force"), Architecture("gru", (4,)), TrainSettings(optimizer="lm")
        )


def test_missing_channel_is_named():
    with pytest.raises(ValueError, match="temperature"):
        train_model(lagged_damper(500), FeatureSpec((Tap("temperature"),), "force"))


def test_workflow_writes_a_verified_onnx_with_channel_ports(tmp_path):
    from nnfmu.data import save_measurement
    from nnfmu.workflows.train import TrainRequest, train_from_file

    data = save_measurement(lagged_damper(2000), tmp_path / "dyno.csv")
    progress: list[float] = []
    outcome = train_from_file(
        data,
        TrainRequest(preset="damper-spline", restarts=1, max_epochs=20),
        tmp_path / "model.onnx",
        progress=lambda label, done: progress.append(done),
    )
    assert outcome.path.is_file() and outcome.export.max_relative_error <= 1e-6
    component = Component.from_onnx(onnx.load(outcome.path))
    assert [p.name for p in component.inputs] == ["velocity"] and [p.name for p in component.outputs] == ["force"]
    assert component.metadata["metrics"]["test"]["nrmse"] == pytest.approx(outcome.metrics["test"].nrmse)
    assert progress and progress[-1] == pytest.approx(1.0) and progress == sorted(progress)


def test_workflow_with_input_selection_exports_the_chosen_channels(tmp_path):
    from nnfmu.data import save_measurement
    from nnfmu.workflows.train import TrainRequest, train_from_file

    data = save_measurement(lagged_damper(2000), tmp_path / "dyno.csv")
    outcome = train_from_file(
        data,
        TrainRequest(preset="damper-hysteresis", select_inputs=True, hidden=(3,), restarts=1, max_epochs=15),
        tmp_path / "selected.onnx",
    )
    assert outcome.selection is not None and len(outcome.selection.ranking) == 9  # x, v, a at delays 0, 1, 2
    component = Component.from_onnx(onnx.load(outcome.path))
    assert [p.name for p in component.inputs] == outcome.selection.spec.channels
    assert outcome.model.spec == outcome.selection.spec


def test_workflow_compensates_the_dyno_moving_mass_before_training(tmp_path):
    """moving_mass: the network is fitted to force - m·a; the data note and the model's description say so."""
    from nnfmu.data import save_measurement
    from nnfmu.workflows.train import TrainRequest, train_from_file

    measured = lagged_damper(2000)
    data = save_measurement(measured, tmp_path / "dyno.csv")
    request = TrainRequest(preset="damper-spline", restarts=1, max_epochs=20, moving_mass=50.0)
    outcome = train_from_file(data, request, tmp_path / "model.onnx")
    assert any("force compensated for 50 kg of moving mass" in note for note in outcome.data_notes)
    assert "(force compensated for 50 kg of moving mass)" in Component.from_onnx(onnx.load(outcome.path)).description
    inertia = 50.0 * np.gradient(measured["velocity"], measured.time)
    assert np.std(inertia) > 0.05 * np.std(measured["force"])  # so the target the metrics score really changed
    plain = train_from_file(data, TrainRequest(preset="damper-spline", restarts=1, max_epochs=20), tmp_path / "p.onnx")
    compensated = measured["force"] - inertia
    assert outcome.model.target_scaler.hi == pytest.approx(compensated.max(), rel=0.02)  # fitted to force - m·a
    assert plain.model.target_scaler.hi == pytest.approx(measured["force"].max(), rel=1e-12)


def test_the_axial_force_preset_on_a_small_motion_keeps_the_stops_it_slips_and_says_which_it_left_out(tmp_path):
    """A bushing moved ±60 um about its working point (as in a car): the preset's 100-400 um stops never slip and are
    left out, named in the outcome's training notes; the 25 and 50 um ones stay in the exported graph."""
    from nnfmu.data import save_measurement
    from nnfmu.workflows.train import TrainRequest, train_from_file

    n = 4000
    t = np.arange(n) * T
    x = 110e-6 + 60e-6 * np.sin(2 * np.pi * 3.0 * t) * np.sin(2 * np.pi * 0.25 * t)
    v = np.gradient(x, T)
    record = Measurement(
        time=t,
        channels={"axial_displacement": x, "axial_velocity": v, "axial_force": 1.3e6 * x + 800.0 * v},
        units={"axial_displacement": "m", "axial_velocity": "m/s", "axial_force": "N"},
        source="synthetic bushing in a car",
    )
    data = save_measurement(record, tmp_path / "bushing.csv")
    request = TrainRequest(preset="bushing-axial-force", hidden=(3,), restarts=1, max_epochs=5)
    outcome = train_from_file(data, request, tmp_path / "axial.onnx")
    kept = [d.name for d in outcome.model.spec.derived if isinstance(d, Stop)]
    assert kept == ["stop(axial_displacement, radius=2.5e-05)", "stop(axial_displacement, radius=5e-05)"]
    # (a five-epoch network may also be refused by the passivity check: that note is not about the stops)
    assert [note.split(" left out")[0] for note in outcome.training_notes if " left out" in note] == [
        f"stop(axial_displacement, radius={r})" for r in ("0.0001", "0.0002", "0.0004")
    ]
    metadata = {p.key: p.value for p in onnx.load(outcome.path).metadata_props}["nnfmu.component"]
    assert sorted(set(re.findall(r"stop\(axial_displacement, radius=[0-9.e-]+\)", metadata))) == sorted(kept)


def test_a_small_half_is_never_lent():
    # Handing a task to another thread costs more than a small half's products.
    x, y = teacher_data(301, seed=2)
    lent = []
    torch.manual_seed(4)
    fit_lm(
        MLP(1, 3), (x[::2], y[::2]), (x[1::2], y[1::2]), LMSettings(max_epochs=5), lend=lambda task: lent.append(task)
    )
    assert lent == []
