"""The loop's building blocks: the running-mean-square feature against its step graph and an analytic response,
the warm start that starts exactly where the old model stands, and the record's fit/diagnosis/test blocks. (Each
effect's feature-spec extension: tests/diagnosis/test_extensions.py.)"""

from __future__ import annotations

from functools import cache

import numpy as np
import onnxruntime as ort
import pytest
import torch

from nnfmu.data import Measurement
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.diagnosis import EFFECTS, DiagnosisSettings
from nnfmu.export.graph import GraphBuilder
from nnfmu.models import Architecture, TrainSettings, train_model
from nnfmu.models import lm as lm_module
from nnfmu.models import retrain as warm_start_module
from nnfmu.models.features import FeatureSpec, LowpassSquare, Tap, derived_from_dict
from nnfmu.models.networks import MLP
from nnfmu.models.retrain import RetrainSettings, _warm_network, fresh_start, retrain, warm_start
from nnfmu.models.stopping import FitHistory
from nnfmu.workflows.loop import LoopError, LoopSettings, plan_blocks

T = 0.001
SPEC = FeatureSpec((Tap("velocity", (0, 2)),), "force")


@cache
def rig() -> Measurement:
    return simulate_rig(
        "damper", RigOptions(duration=6.0, seed=2, excitation="random", effects=("inertia", "temperature"))
    ).measurement


@cache
def small_model():
    return train_model(rig(), SPEC, Architecture("mlp", (3,)), TrainSettings(max_epochs=20, restarts=1)).model


def test_lowpass_square_step_response_is_the_exact_exponential_of_the_square():
    spec = FeatureSpec((), "force", (LowpassSquare("velocity", tau=0.004),))
    k = np.arange(40)
    y = spec.features({"velocity": np.full(40, 3.0)}, T)[:, 0]
    np.testing.assert_allclose(y, 9.0 * (1.0 - np.exp(-(k + 1) * T / 0.004)), rtol=1e-13)


def test_lowpass_square_step_nodes_equal_numpy_sample_by_sample():
    spec = FeatureSpec((Tap("velocity", (0, 1)),), "force", (LowpassSquare("velocity", tau=0.01),))
    x = np.random.default_rng(4).normal(size=50)
    g = GraphBuilder(reserved=["velocity", "state", "features_out", "state_next"])
    features, state_next = spec.emit(g, {"velocity": "velocity"}, "state", T)
    g.output(features, "features_out")
    g.output(state_next, "state_next")
    graph = g.model(
        "f",
        "test",
        [("velocity", 1), ("state", spec.state_size)],
        [("features_out", spec.n_features), ("state_next", spec.state_size)],
    )
    session = ort.InferenceSession(graph.SerializeToString())
    state, rows = np.zeros(spec.state_size), []
    for k in range(len(x)):
        out, state = session.run(None, {"velocity": x[k : k + 1], "state": state})
        rows.append(out)
    np.testing.assert_allclose(np.array(rows), spec.features({"velocity": x}, T), rtol=1e-13, atol=1e-15)


def test_lowpass_square_round_trips_and_refuses_a_bad_tau():
    feature = LowpassSquare("velocity", tau=2.5)
    assert derived_from_dict(feature.to_dict()) == feature
    with pytest.raises(ValueError, match="tau"):
        LowpassSquare("velocity", tau=-1.0)


def test_warm_started_network_starts_exactly_at_the_old_model():
    """Old columns carry the old scaled features, the new column anything: the output is the old model's."""
    model = small_model()
    m = rig()
    ext = EFFECTS["gas_force"].extension(SPEC, m, np.arange(len(m)), DiagnosisSettings())
    network = _warm_network(model, ext.spec, extra=3, seed=0)
    scaled = model.feature_scaler.scale(SPEC.features({"velocity": m["velocity"]}, T))
    full = np.full((len(m), ext.spec.n_features), 123.0)
    full[:, [ext.spec.feature_names.index(n) for n in SPEC.feature_names]] = scaled
    with torch.no_grad():
        new = network(torch.from_numpy(full))[:, 0].numpy()
        old = model.network(torch.from_numpy(scaled))[:, 0].numpy()
    np.testing.assert_allclose(new, old, rtol=1e-12, atol=1e-12)


def test_warm_start_keeps_old_scalers_and_lowers_the_validation_error():
    model = small_model()
    m = rig()
    blocks = plan_blocks(len(m), LoopSettings(diagnosis=LoopSettings().diagnosis), m.source)
    ext = EFFECTS["temperature"].extension(SPEC, m, blocks.rows("train"), DiagnosisSettings())
    result = warm_start(
        model,
        ext.spec,
        m,
        blocks.rows("train"),
        blocks.rows("validation"),
        LoopSettings(max_epochs=30, extra_hidden=(0, 2), lm_max_samples=3000).retrain_settings(),
        "temperature",
    )
    new = result.model
    np.testing.assert_array_equal(new.feature_scaler.lo[:2], model.feature_scaler.lo)
    np.testing.assert_array_equal(new.feature_scaler.hi[:2], model.feature_scaler.hi)
    train = blocks.rows("train")
    assert new.feature_scaler.lo[2] == pytest.approx(np.min(m["temperature"][train]))
    assert set(result.validation_mse) == {0, 2} and result.extra_hidden in (0, 2)
    assert new.network.hidden.out_features == 3 + result.extra_hidden
    assert new.settings["retraining"]["effect"] == "temperature"
    # the band each input was trained on is kept or widened, the new input's added
    assert model.band and all(new.band[c] >= edge for c, edge in model.band.items())
    assert new.band.keys() == set(ext.spec.channels)


def test_a_retraining_gives_the_same_network_with_a_second_core_or_without(monkeypatch):
    # A lone fit lends half of each epoch's JᵀJ to an idle core when there is one; the sums are the same either way.
    monkeypatch.setattr(lm_module, "MIN_LENT_JACOBIAN", 0)  # lent however small the half
    m = rig()
    blocks = plan_blocks(len(m), LoopSettings(), m.source)
    ext = EFFECTS["temperature"].extension(SPEC, m, blocks.rows("train"), DiagnosisSettings())
    settings = LoopSettings(max_epochs=10, extra_hidden=(2,), lm_max_samples=2000).retrain_settings()
    networks, lent = [], []

    class Counted(warm_start_module.SpareCores):
        def lend(self, task):
            future = super().lend(task)
            lent[-1] += future is not None
            return future

    monkeypatch.setattr(warm_start_module, "SpareCores", Counted)
    for cores in (1, 2):
        monkeypatch.setattr(warm_start_module, "usable_cores", lambda cores=cores: cores)
        lent.append(0)
        trained = warm_start(small_model(), ext.spec, m, blocks.rows("train"), blocks.rows("validation"), settings, "t")
        networks.append(trained.model.network)
    assert lent[0] == 0 and lent[1] > 0  # one core lends nothing; with two the fit's epochs were lent
    for a, b in zip(*(net.parameters() for net in networks)):
        assert torch.equal(a, b)


def test_fresh_start_trains_a_seeded_network_of_the_given_size_on_the_extended_inputs():
    model = small_model()
    m = rig()
    blocks = plan_blocks(len(m), LoopSettings(), m.source)
    train, validation = blocks.rows("train"), blocks.rows("validation")
    ext = EFFECTS["temperature"].extension(SPEC, m, train, DiagnosisSettings())
    settings = LoopSettings(max_epochs=30, lm_max_samples=3000).retrain_settings()
    result = fresh_start(model, ext.spec, m, train, validation, settings, "temperature", hidden=5)
    new = result.model
    assert result.start == "fresh" and new.settings["retraining"]["start"] == "fresh"
    assert new.network.hidden.out_features == 5 and result.extra_hidden == 2 and set(result.validation_mse) == {2}
    np.testing.assert_array_equal(new.feature_scaler.lo[:2], model.feature_scaler.lo)
    # trained: below the validation MSE of the same seeded draw untrained
    torch.manual_seed(settings.seed)
    untrained = MLP(ext.spec.n_features, 5)
    x = torch.from_numpy(new.feature_scaler.scale(ext.spec.features({c: m[c] for c in ext.spec.channels}, T)))
    y = model.target_scaler.scale(np.asarray(m["force"]))
    with torch.no_grad():
        initial = float(np.mean((untrained(x)[:, 0].numpy()[validation] - y[validation]) ** 2))
    assert result.validation_mse[2] < 0.5 * initial
    again = fresh_start(model, ext.spec, m, train, validation, settings, "temperature", hidden=5)
    torch.testing.assert_close(again.model.network.hidden.weight, new.network.hidden.weight, rtol=0, atol=0)


def test_warm_start_tries_more_hidden_units_only_while_they_help(monkeypatch):
    """Validation MSE falls from 0 to 2 extra units and rises at 4: 8 is never tried, 2 is kept."""
    losses = {3: 0.5, 5: 0.3, 7: 0.4, 11: 0.1}  # by the network's hidden units (3 copied)
    tried = []

    def fake_fit(network, train, validation, settings, **lent):
        tried.append(network.hidden.out_features)
        return FitHistory([1.0], [losses[network.hidden.out_features]], 0, "fake")

    monkeypatch.setattr(warm_start_module, "fit_lm", fake_fit)
    m = rig()
    blocks = plan_blocks(len(m), LoopSettings(), m.source)
    ext = EFFECTS["temperature"].extension(SPEC, m, blocks.rows("train"), DiagnosisSettings())
    result = warm_start(
        small_model(),
        ext.spec,
        m,
        blocks.rows("train"),
        blocks.rows("validation"),
        LoopSettings(extra_hidden=(0, 2, 4, 8)).retrain_settings(),
        "temperature",
    )
    assert tried == [3, 5, 7] and result.extra_hidden == 2 and result.validation_mse == {0: 0.5, 2: 0.3, 4: 0.4}
    with pytest.raises(LoopError, match="rising order"):
        LoopSettings(extra_hidden=(0, 6, 3))


def test_retraining_steps_in_its_own_input_coordinates_whatever_the_first_fits(monkeypatch):
    old = train_model(
        rig(), SPEC, Architecture("mlp", (3,)), TrainSettings(max_epochs=5, restarts=1, lm_inputs="whitened")
    ).model
    seen = []
    real = warm_start_module.fit_lm

    def spy(network, train, validation, settings, **lent):
        seen.append(settings.inputs)
        return real(network, train, validation, settings, **lent)

    monkeypatch.setattr(warm_start_module, "fit_lm", spy)
    m = rig()
    blocks = plan_blocks(len(m), LoopSettings(), m.source)
    train, validation = blocks.rows("train"), blocks.rows("validation")
    ext = EFFECTS["temperature"].extension(SPEC, m, train, DiagnosisSettings())
    for inputs in ("raw", "standardised"):
        seen.clear()
        settings = LoopSettings(max_epochs=3, extra_hidden=(2,), lm_max_samples=2000, lm_inputs=inputs)
        warm = warm_start(old, ext.spec, m, train, validation, settings.retrain_settings(), "temperature")
        fresh = fresh_start(old, ext.spec, m, train, validation, settings.retrain_settings(), "temperature", hidden=5)
        assert seen == [inputs, inputs]
        assert (
            warm.model.settings["retraining"]["lm_inputs"] == fresh.model.settings["retraining"]["lm_inputs"] == inputs
        )
        assert warm.model.settings["lm_inputs"] == "whitened"  # the first fit's, as it was trained
    assert LoopSettings().retrain_settings().lm_inputs == "raw"  # the default (measured: LoopSettings.lm_inputs)
    with pytest.raises(LoopError, match="'polar'"):
        LoopSettings(lm_inputs="polar")


def test_blocks_interleave_fit_diagnosis_and_test_without_overlap():
    blocks = plan_blocks(10000, LoopSettings(), "record")
    parts = {p: blocks.rows(p) for p in ("train", "validation", "diagnosis", "test")}
    joined = np.concatenate(list(parts.values()))
    assert len(joined) == 10000 and len(np.unique(joined)) == 10000
    assert len(parts["diagnosis"]) == 2000 and len(parts["test"]) == 2000
    assert len(blocks.ranges["test"]) == 5  # one test block per segment
    with pytest.raises(LoopError, match="4900 samples are too short"):
        plan_blocks(4900, LoopSettings(), "record")


def test_retrain_starts_warm_or_fresh_and_refuses_anything_else():
    m = rig()
    blocks = plan_blocks(len(m), LoopSettings(), m.source)
    train, validation = blocks.rows("train"), blocks.rows("validation")
    ext = EFFECTS["temperature"].extension(SPEC, m, train, DiagnosisSettings())
    settings = RetrainSettings(max_epochs=5, lm_max_samples=2000)
    warm = retrain(small_model(), ext.spec, m, train, validation, settings, "temperature")
    fresh = retrain(small_model(), ext.spec, m, train, validation, settings, "temperature", start="fresh", hidden=4)
    assert (warm.start, fresh.start, fresh.model.network.hidden.out_features) == ("warm", "fresh", 4)
    with pytest.raises(ValueError, match="start must be 'warm' or 'fresh'"):
        retrain(small_model(), ext.spec, m, train, validation, settings, "temperature", start="lukewarm")
    with pytest.raises(ValueError, match="rising order"):
        RetrainSettings(extra_hidden=(3, 1))
