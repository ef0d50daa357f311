"""Feature specs: validation, analytic values, and equality with the emitted ONNX nodes run sample by sample."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import onnxruntime as ort
import pytest

from nnfmu.export.graph import GraphBuilder
from nnfmu.models.features import (
    STARTED,
    Difference,
    FeatureSpec,
    Highpass,
    Lowpass,
    LowpassSquare,
    SmoothSign,
    Stop,
    Tap,
    derived_from_dict,
)

T = 0.001


def spec_with_everything() -> FeatureSpec:
    return FeatureSpec(
        taps=(Tap("velocity", (0, 1, 3)), Tap("displacement", (2,)), Tap("temperature")),
        output="force",
        derived=(SmoothSign("velocity", scale=0.05), Lowpass("velocity", tau=0.004), Lowpass("acceleration", tau=0.01)),
    )


def spec_with_rates_and_memory() -> FeatureSpec:
    """Highpass and difference features beside a tap and a low-pass of the same channel (their states interleave)."""
    return FeatureSpec(
        taps=(Tap("displacement", (0, 1)),),
        output="force",
        derived=(
            Highpass("displacement", tau=0.002),
            Difference("velocity", delay=1),
            Lowpass("displacement", tau=0.002),
            Difference("displacement", delay=4),
            Highpass("velocity", tau=0.05),
        ),
    )


def spec_with_friction_relaxed() -> FeatureSpec:
    """Every kind of state slot, started relaxed at the first input: delay line, low-pass (of the square too),
    high-pass, difference and stop operators narrower and wider than the motion."""
    return FeatureSpec(
        taps=(Tap("displacement", (0, 2)), Tap("velocity")),
        output="force",
        derived=(
            Highpass("displacement", tau=0.01),
            Stop("displacement", radius=0.05),
            Stop("displacement", radius=5.0),
            LowpassSquare("velocity", tau=0.02),
            Difference("velocity", delay=3),
            Lowpass("displacement", tau=0.004),
        ),
        relaxed_start=True,
    )


def relaxed(make):
    """The spec `make` builds, started relaxed at its first input."""
    return lambda: replace(make(), relaxed_start=True)


def run_feature_nodes(spec: FeatureSpec, channels: dict[str, np.ndarray]) -> np.ndarray:
    """The emitted feature nodes as a graph of their own, run in onnxruntime one sample at a time from rest."""
    g = GraphBuilder(reserved=[*spec.channels, "state", "features_out", "state_next"])
    state = "state" if spec.state_size else None
    features, state_next = spec.emit(g, {c: c for c in spec.channels}, state, T)
    outputs = [("features_out", spec.n_features)]
    g.output(features, "features_out")
    if state_next is not None:
        g.output(state_next, "state_next")
        outputs.append(("state_next", spec.state_size))
    inputs = [(c, 1) for c in spec.channels] + ([("state", spec.state_size)] if state else [])
    session = ort.InferenceSession(g.model("features", "test", inputs, outputs).SerializeToString())
    s = np.array([slot.initial for slot in spec.state_layout()])
    rows = []
    for k in range(len(next(iter(channels.values())))):
        feed = {c: channels[c][k : k + 1] for c in spec.channels}
        if state:
            feed["state"] = s
        result = session.run(None, feed)
        rows.append(result[0])
        if state:
            s = result[1]
    return np.array(rows)


def test_names_channels_and_state_layout():
    spec = spec_with_everything()
    assert spec.channels == ["velocity", "displacement", "temperature", "acceleration"]
    assert spec.feature_names == [
        "velocity[k]",
        "velocity[k-1]",
        "velocity[k-3]",
        "displacement[k-2]",
        "temperature[k]",
        "smooth_sign(velocity, scale=0.05)",
        "lowpass(velocity, tau=0.004)",
        "lowpass(acceleration, tau=0.01)",
    ]
    assert spec.n_features == 8
    layout = spec.state_layout()
    assert [s.name for s in layout] == [
        "velocity[k-1]",
        "velocity[k-2]",
        "velocity[k-3]",
        "displacement[k-1]",
        "displacement[k-2]",
        "lowpass(velocity, tau=0.004)[k-1]",
        "lowpass(acceleration, tau=0.01)[k-1]",
    ]
    assert [s.channel for s in layout] == ["velocity"] * 3 + ["displacement"] * 2 + ["velocity", "acceleration"]
    assert all(s.initial == 0.0 for s in layout) and spec.state_size == 7


def test_delays_start_from_rest_and_shift():
    spec = FeatureSpec(taps=(Tap("velocity", (0, 2)),), output="force")
    x = np.array([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(spec.features({"velocity": x}, T), [[1, 0], [2, 0], [3, 1], [4, 2]])


def test_lowpass_step_response_is_exact_exponential():
    tau = 0.003
    spec = FeatureSpec(taps=(), output="force", derived=(Lowpass("velocity", tau=tau),))
    k = np.arange(50)
    y = spec.features({"velocity": np.ones(50)}, T)[:, 0]
    np.testing.assert_allclose(y, 1.0 - np.exp(-(k + 1) * T / tau), rtol=1e-13)


def test_smooth_sign_is_tanh_of_scaled_channel():
    spec = FeatureSpec(taps=(), output="force", derived=(SmoothSign("velocity", scale=0.2),))
    v = np.linspace(-1, 1, 11)
    np.testing.assert_array_equal(spec.features({"velocity": v}, T)[:, 0], np.tanh(v / 0.2))


def test_highpass_is_the_channel_minus_its_lowpass():
    tau = 0.003
    spec = FeatureSpec(taps=(), output="force", derived=(Highpass("velocity", tau=tau),))
    k = np.arange(50)
    y = spec.features({"velocity": np.ones(50)}, T)[:, 0]
    np.testing.assert_allclose(y, np.exp(-(k + 1) * T / tau), rtol=1e-12, atol=1e-15)  # 1 - lowpass step response
    x = np.random.default_rng(3).normal(size=80)
    low = FeatureSpec(taps=(), output="force", derived=(Lowpass("velocity", tau=tau),)).features({"velocity": x}, T)
    np.testing.assert_allclose(spec.features({"velocity": x}, T)[:, 0], x - low[:, 0], rtol=0, atol=1e-15)
    assert [s.name for s in spec.state_layout()] == ["highpass(velocity, tau=0.003).lowpass[k-1]"]


def test_difference_is_the_change_over_its_delay_from_rest():
    spec = FeatureSpec(taps=(), output="force", derived=(Difference("velocity", delay=2),))
    x = np.array([1.0, 3.0, 6.0, 10.0, 15.0])
    np.testing.assert_array_equal(spec.features({"velocity": x}, T)[:, 0], [1.0, 3.0, 5.0, 7.0, 9.0])
    assert spec.feature_names == ["difference(velocity, delay=2)"] and spec.state_size == 2


@pytest.mark.parametrize(
    "make",
    [
        spec_with_everything,
        spec_with_rates_and_memory,
        lambda: FeatureSpec((Tap("velocity"),), "force"),
        spec_with_friction_relaxed,
        relaxed(spec_with_everything),
        relaxed(spec_with_rates_and_memory),
    ],
)
def test_features_equal_emitted_step_nodes(make):
    """numpy features (a relaxed spec: started at its first values) equal the graph run sample by sample from the
    initial state its layout gives (a relaxed spec's graph relaxes itself at the first sample)."""
    spec = make()
    rng = np.random.default_rng(1)
    channels = {c: 3.0 + rng.normal(size=60) for c in spec.channels}  # far from rest at the first sample
    ulps = 8 * np.finfo(float).eps * 3.0  # a difference of a few rounding steps of the inputs (a high-pass of ~3 + x)
    np.testing.assert_allclose(run_feature_nodes(spec, channels), spec.features(channels, T), rtol=1e-13, atol=ulps)


def test_relaxed_start_holds_every_memory_at_a_constant_deflected_input():
    """Held at its first value, a relaxed spec's step graph keeps every memory feature exactly at rest: high-pass,
    difference and stop 0, low-pass and delay line the value, the low-passed square its square (numpy's filters within
    rounding); from rest they would all move."""
    spec = spec_with_friction_relaxed()
    channels = {"displacement": np.full(40, 0.7), "velocity": np.full(40, -0.3)}
    graph = run_feature_nodes(spec, channels)
    np.testing.assert_allclose(spec.features(channels, T), graph, rtol=0, atol=4 * np.finfo(float).eps)
    features = dict(zip(spec.feature_names, graph.T))
    for name, column in features.items():
        if name.startswith(("highpass", "stop", "difference")):
            np.testing.assert_array_equal(column, 0.0, err_msg=name)
    np.testing.assert_array_equal(features["displacement[k-2]"], 0.7)
    np.testing.assert_array_equal(features["lowpass(displacement, tau=0.004)"], 0.7)
    np.testing.assert_array_equal(features["lowpass_square(velocity, tau=0.02)"], (-0.3) ** 2)
    at_rest = dict(zip(spec.feature_names, replace(spec, relaxed_start=False).features(channels, T).T))
    assert at_rest["highpass(displacement, tau=0.01)"][0] == pytest.approx(0.7 * 0.9, rel=0.02)
    assert at_rest["stop(displacement, radius=0.05)"][0] == pytest.approx(0.05)


def test_relaxed_start_at_rest_inputs_reproduces_the_rest_spec_bit_for_bit():
    """Started at zero inputs, the relaxed graph sets its slots to the rest values, and from then on multiplies the
    held state by exactly 1: the same features, bit for bit, as the spec without the option."""
    spec = spec_with_friction_relaxed()
    rng = np.random.default_rng(2)
    channels = {c: np.concatenate([[0.0], rng.normal(size=50)]) for c in spec.channels}
    np.testing.assert_array_equal(
        run_feature_nodes(spec, channels), run_feature_nodes(replace(spec, relaxed_start=False), channels)
    )


def test_relaxed_start_adds_one_flag_slot_and_only_when_there_is_state():
    spec = spec_with_friction_relaxed()
    layout = spec.state_layout()
    assert layout[-1].name == STARTED and layout[-1].initial == 0.0
    assert layout[:-1] == replace(spec, relaxed_start=False).state_layout()
    stateless = FeatureSpec((Tap("velocity"),), "force", (SmoothSign("velocity"),), relaxed_start=True)
    assert stateless.state_size == 0
    assert "relaxed_start" not in spec_with_everything().to_dict()  # the rest spec's metadata is as before


@pytest.mark.parametrize("make", [spec_with_everything, spec_with_rates_and_memory, spec_with_friction_relaxed])
def test_dict_round_trip_through_json(make):
    spec = make()
    again = FeatureSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec


@pytest.mark.parametrize(
    "build, fragment",
    [
        (lambda: Tap("velocity", (0, -1)), "-1"),
        (lambda: Tap("velocity", (1, 1)), "duplicate delay"),
        (lambda: Tap("", (0,)), "''"),
        (lambda: FeatureSpec((Tap("velocity"), Tap("velocity", (1,))), "force"), "'velocity' is tapped twice"),
        (
            lambda: FeatureSpec((Tap("velocity"),), "force", (SmoothSign("velocity"), SmoothSign("velocity"))),
            "duplicate feature names",
        ),
        (lambda: FeatureSpec((Tap("force"),), "force"), "'force' is also an input"),
        (lambda: FeatureSpec((), "force"), "no features"),
        (lambda: Lowpass("velocity", tau=0.0), "tau"),
        (lambda: Highpass("velocity", tau=-1.0), "tau must be a finite number > 0, got -1.0"),
        (lambda: Difference("velocity", delay=0), "delay must be an integer >= 1, got 0"),
        (lambda: Difference("velocity", delay=1.5), "1.5"),
        (lambda: SmoothSign("velocity", scale=float("nan")), "nan"),
        (lambda: derived_from_dict({"kind": "energy", "channel": "velocity"}), "'energy'"),
        (lambda: derived_from_dict({"kind": "lowpass", "channel": "velocity", "cutoff": 3}), "cutoff"),
        (lambda: FeatureSpec((Tap("velocity"),), "force", relaxed_start=1), "relaxed_start must be true or false"),
        (
            lambda: FeatureSpec.from_dict({"taps": [{"channel": "v"}], "output": "f", "relaxed_start": "yes"}),
            "relaxed_start is 'yes'",
        ),
    ],
)
def test_invalid_specs_raise_value_error_naming_the_value(build, fragment):
    with pytest.raises(ValueError, match=fragment.replace("(", r"\(").replace("[", r"\[")):
        build()


def test_missing_or_mismatched_channels_raise():
    spec = FeatureSpec((Tap("velocity"), Tap("displacement", (1,))), "force")
    with pytest.raises(ValueError, match="'displacement' missing"):
        spec.features({"velocity": np.zeros(3)}, T)
    with pytest.raises(ValueError, match="different lengths"):
        spec.features({"velocity": np.zeros(3), "displacement": np.zeros(4)}, T)
    with pytest.raises(ValueError, match="sample period"):
        spec.features({"velocity": np.zeros(3), "displacement": np.zeros(3)}, 0.0)
