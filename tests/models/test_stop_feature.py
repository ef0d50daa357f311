"""The stop-operator feature (backlash gap position): analytic values, its play-operator state, and equality with the
emitted ONNX nodes run sample by sample in onnxruntime."""

from __future__ import annotations

import numpy as np
import pytest

from nnfmu.models.features import FeatureSpec, Stop, Tap, derived_from_dict

from .test_features import T, run_feature_nodes


def stop_spec(radius: float) -> FeatureSpec:
    return FeatureSpec(taps=(), output="force", derived=(Stop("displacement", radius=radius),))


def test_stop_follows_the_motion_inside_the_gap_and_saturates_at_its_half_width():
    """A triangle wave of amplitude 3 through a gap of half-width 1: from rest the driven side stays at 0 until x
    reaches 1; after each reversal s falls by the travel since the reversal, until it reaches -1 (2 of travel)."""
    x = np.array([0.0, 0.5, 1.0, 2.0, 3.0, 2.5, 2.0, 1.0, 0.0, 1.0, 1.5, 3.0])
    expected = [0.0, 0.5, 1.0, 1.0, 1.0, 0.5, 0.0, -1.0, -1.0, 0.0, 0.5, 1.0]
    np.testing.assert_array_equal(stop_spec(1.0).features({"displacement": x}, T)[:, 0], expected)


def test_stop_is_independent_of_where_the_motion_is_centred():
    t = np.arange(400) * T
    x = 0.02 * np.sin(2 * np.pi * 5 * t)
    spec = stop_spec(0.004)
    centred = spec.features({"displacement": x}, T)[:, 0]
    shifted = spec.features({"displacement": x + 0.5}, T)[:, 0]
    after_first_reversal = t > 0.1  # the first reversal (t = 0.05 s) has closed the gap: the start is forgotten
    np.testing.assert_allclose(shifted[after_first_reversal], centred[after_first_reversal], rtol=0, atol=1e-12)
    assert np.max(np.abs(centred)) == pytest.approx(0.004)


def test_stop_state_name_round_trip_and_bad_radius():
    stop = Stop("displacement", radius=0.0025)
    assert stop.name == "stop(displacement, radius=0.0025)"
    assert [s.name for s in stop_spec(0.0025).state_layout()] == ["stop(displacement, radius=0.0025).play[k-1]"]
    assert derived_from_dict(stop.to_dict()) == stop
    with pytest.raises(ValueError, match="radius must be a finite number > 0, got 0"):
        Stop("displacement", radius=0)


def test_stop_equals_its_emitted_step_nodes():
    spec = FeatureSpec(
        taps=(Tap("velocity", (0, 1)),),
        output="force",
        derived=(Stop("displacement", radius=0.3), Stop("displacement", radius=1.2), Stop("velocity", radius=0.5)),
    )
    rng = np.random.default_rng(4)
    channels = {"velocity": rng.normal(size=120), "displacement": np.cumsum(rng.normal(size=120))}
    np.testing.assert_allclose(run_feature_nodes(spec, channels), spec.features(channels, T), rtol=1e-13, atol=1e-15)


def noisy_friction_record(n: int = 12000, r: float = 0.002):
    """An elastic-plastic element (k·x plus a friction element of radius r) recorded with transducer noise of r/4:
    (spec, record with the noisy position, clean position, force)."""
    from nnfmu.data.measurement import Measurement

    t = np.arange(n) * T
    rng = np.random.default_rng(7)
    x = sum(
        a * np.sin(2 * np.pi * f * t + p) for a, f, p in zip((0.02, 0.006, 0.003), (0.7, 4.0, 11.0), rng.random(3) * 6)
    )
    spec = FeatureSpec(taps=(Tap("displacement"),), output="force", derived=(Stop("displacement", radius=r),))
    force = 1000.0 * x + 20.0 / r * spec.features({"displacement": x}, T)[:, 1]
    noisy = x + r / 4 * rng.standard_normal(n)
    m = Measurement(t, {"displacement": noisy, "force": force}, {"displacement": "m", "force": "N"}, source="rig")
    return spec, m, x, force


def clean_error(model, x: np.ndarray, force: np.ndarray) -> float:
    return float(np.sqrt(np.mean((model.predict({"displacement": x}) - force) ** 2)) / np.std(force))


@pytest.mark.slow
def test_training_on_low_passed_inputs_removes_the_noise_bias_of_a_stop_feature():
    """The stop feature of the noisy position moves with the noise, so a network trained on it is off on the clean
    motion a simulation feeds it; trained on the inputs low-passed above the motion's band it is not."""
    from nnfmu.models.train import Architecture, TrainSettings, train_model

    spec, m, x, force = noisy_friction_record()
    errors = {}
    for cutoff in (None, 60.0):
        settings = TrainSettings(max_epochs=60, restarts=1, input_cutoff=cutoff)
        model = train_model(m, spec, Architecture("mlp", (3,)), settings).model
        assert model.settings["input_cutoff"] == cutoff
        errors[cutoff] = clean_error(model, x, force)
    assert errors[60.0] < 0.5 * errors[None], errors


def test_retraining_low_passes_the_inputs_as_the_first_fit_did():
    """A fresh retraining of a low-pass-trained network on the same noisy record stays as good on the clean motion
    (it would learn the noise bias from the raw inputs) and keeps the cut-off in its settings."""
    from nnfmu.models.retrain import RetrainSettings, retrain
    from nnfmu.models.train import Architecture, TrainSettings, train_model

    spec, m, x, force = noisy_friction_record()
    first = train_model(m, spec, Architecture("mlp", (3,)), TrainSettings(max_epochs=60, restarts=1, input_cutoff=60.0))
    rows = np.arange(len(force))
    again = retrain(
        first.model,
        spec,
        m,
        rows[: 9 * len(rows) // 10],
        rows[9 * len(rows) // 10 :],
        RetrainSettings(max_epochs=60),
        "again",
        start="fresh",
    ).model
    assert again.settings["input_cutoff"] == 60.0
    assert clean_error(again, x, force) < 2.0 * clean_error(first.model, x, force) + 0.01
