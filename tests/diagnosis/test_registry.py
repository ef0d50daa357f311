"""The effect registry as a whole: every effect provides both halves (regressors for the diagnosis and a model
extension, or an explicit, documented NoExtension), every effect parameter has exactly one owner among the effects,
and the features each extension adds are computed identically by numpy and by the ONNX nodes of the step graph
(the feature nodes alone, column by column, and the whole exported graph of a small network). A measured channel
the model does not use (`input:<channel>`, made per record) is checked the same way."""

from __future__ import annotations

from dataclasses import fields
from functools import cache
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest

from nnfmu.data import Measurement
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.diagnosis import (
    EFFECTS,
    ChannelInput,
    DiagnosisError,
    DiagnosisSettings,
    Effect,
    Extension,
    NoExtension,
    find_effect,
    select_effects,
)
from nnfmu.diagnosis.effects.friction import added_scale
from nnfmu.diagnosis.effects.hysteresis import added_taus
from nnfmu.diagnosis.settings import TEST_FIELDS
from nnfmu.diagnosis.signals import build_signals
from nnfmu.export import export_onnx, run_step_graph
from nnfmu.export.graph import GraphBuilder
from nnfmu.models import Architecture, TrainSettings, train_model
from nnfmu.models.features import FeatureSpec, Lowpass, Tap

# Effects that by design add nothing to the network, and the words their NoExtension must say why with.
NO_EXTENSION = {"sensor_offset": "belongs to the measurement, not to the component"}
# A velocity-history spec with a state of its own, so an extension's states must land after it in the state vector.
SPEC = FeatureSpec((Tap("velocity", (0, 2)),), "force", (Lowpass("velocity", tau=0.05),))
FEATURE_SAMPLES = 400  # samples run through the feature nodes one at a time
# (effect, how the record is changed first): temperature once measured and once not (a running mean square of
# velocity stands in), inertia once from a measured acceleration and once from velocity taps; the channel candidate
# on a record with a coil voltage the model does not use.
CHANNEL = "input:voltage"
CASES = [
    ("seal_friction", "rig"),
    ("gas_force", "rig"),
    ("hysteresis", "rig"),
    ("backlash", "rig"),
    ("presliding_friction", "rig"),
    ("inertia", "rig"),
    ("inertia", "with_acceleration"),
    ("temperature", "rig"),
    ("temperature", "no_temperature"),
    ("frequency_dependence", "rig"),
    ("amplitude_dependence", "rig"),
    (CHANNEL, "with_voltage"),
]


@cache
def record(variant: str) -> Measurement:
    """A 3 s random-drive damper record (displacement, velocity, temperature, force), changed as `variant` says."""
    m = simulate_rig(
        "damper", RigOptions(duration=3.0, seed=2, excitation="random", effects=("inertia", "temperature"))
    ).measurement
    channels = dict(m.channels)
    if variant == "no_temperature":
        del channels["temperature"]
    elif variant == "with_acceleration":
        channels["acceleration"] = np.gradient(m["velocity"], m.sample_period)
    elif variant == "with_voltage":  # a coil voltage held in random steps of 0.1 s, 0-5 V
        steps = np.random.default_rng(4).uniform(0.0, 5.0, len(m) // 100 + 1)
        channels["voltage"] = np.repeat(steps, 100)[: len(m)]
    units = {**m.units, "acceleration": "m/s^2", "voltage": "V"}
    return Measurement(m.time, channels, {k: units[k] for k in channels}, f"{m.source} ({variant})")


def extension_of(effect: str, variant: str) -> Extension:
    m = record(variant)
    ext = find_effect(effect).extension(SPEC, m, np.arange(len(m) // 2), DiagnosisSettings())
    assert isinstance(ext, Extension), ext
    return ext


def run_feature_nodes(spec: FeatureSpec, channels: dict[str, np.ndarray], dt: float) -> np.ndarray:
    """The spec's emitted feature nodes as a graph of their own, run in onnxruntime one sample at a time from its
    initial state."""
    g = GraphBuilder(reserved=[*spec.channels, "state", "features_out", "state_next"])
    features, state_next = spec.emit(g, {c: c for c in spec.channels}, "state", dt)
    g.output(features, "features_out")
    g.output(state_next, "state_next")
    inputs = [(c, 1) for c in spec.channels] + [("state", spec.state_size)]
    outputs = [("features_out", spec.n_features), ("state_next", spec.state_size)]
    session = ort.InferenceSession(g.model("features", "test", inputs, outputs).SerializeToString())
    state = np.array([slot.initial for slot in spec.state_layout()])
    rows = []
    for k in range(len(next(iter(channels.values())))):
        out, state = session.run(None, {**{c: channels[c][k : k + 1] for c in spec.channels}, "state": state})
        rows.append(out)
    return np.array(rows)


def test_the_registry_is_keyed_by_each_effects_own_name_and_every_effect_has_both_halves():
    assert len(EFFECTS) == 10
    for name, effect in EFFECTS.items():
        assert isinstance(effect, Effect) and effect.name == name
        assert effect.description and isinstance(effect.requires, tuple)
        assert type(effect).regressors is not Effect.regressors
        assert type(effect).extension is not Effect.extension
        assert type(effect).extension.__doc__, f"{name}'s extension must say what it adds or why it adds nothing"
    extending = {name for name, _ in CASES} - {CHANNEL}
    assert extending | set(NO_EXTENSION) == set(EFFECTS) and not extending & set(NO_EXTENSION)
    channel = find_effect(CHANNEL)
    assert isinstance(channel, ChannelInput) and channel.name == CHANNEL and channel.channel == "voltage"
    assert CHANNEL not in EFFECTS  # made per record, not registered


def test_every_effect_parameter_has_one_owner_and_every_owner_reads_a_real_setting():
    names = {f.name for f in fields(DiagnosisSettings)}
    claimed = [p for effect in (*EFFECTS.values(), find_effect(CHANNEL)) for p in effect.parameters]
    assert set(claimed) <= names
    assert set(claimed) == names - set(TEST_FIELDS)  # no setting of an effect without an effect reading it
    # reversal_fractions is the one parameter several effects share: the travel after a reversal, for the build-up
    # (hysteresis), the gap (backlash) and the seal's pre-sliding travel (presliding_friction)
    shared = {p for p in claimed if claimed.count(p) > 1}
    assert shared == {"reversal_fractions"}


def test_the_extension_picks_its_values_from_the_tuples_the_diagnosis_tries():
    settings = DiagnosisSettings()
    assert added_scale(settings) == 0.02 and added_scale(settings) in settings.friction_scales
    assert added_taus(settings) == (0.002, 0.02) and set(added_taus(settings)) <= set(settings.memory_times)
    assert added_scale(DiagnosisSettings(friction_scales=(0.3, 0.01, 0.05))) == 0.05  # the middle once sorted
    assert added_taus(DiagnosisSettings(memory_times=(0.01,))) == (0.01,)
    m = record("rig")
    signals = build_signals(m, m["force"] + 1.0, "force", ("velocity",))
    one_tau = DiagnosisSettings(frequency_taus=(0.05,))
    regressors = EFFECTS["frequency_dependence"].regressors(signals, one_tau)
    ext = EFFECTS["frequency_dependence"].extension(SPEC, m, np.arange(len(m)), one_tau)
    assert regressors.names == ("displacement - lowpass(displacement, 0.05 s)",)
    assert ext.added == ("lowpass(displacement, tau=0.05)",)  # one setting moves both halves
    with_voltage = record("with_voltage")
    signals = build_signals(with_voltage, with_voltage["force"] + 1.0, "force", ("velocity",))
    one_tau = DiagnosisSettings(channel_taus=(0.05,))
    regressors = find_effect(CHANNEL).regressors(signals, one_tau)
    ext = find_effect(CHANNEL).extension(SPEC, with_voltage, np.arange(len(with_voltage)), one_tau)
    assert regressors.names == (
        "voltage - its mean",
        "lowpass(voltage, 0.05 s) - its mean",
        "(voltage - its mean) * predicted force",
        "(lowpass(voltage, 0.05 s) - its mean) * predicted force",
    )
    assert np.allclose(regressors.matrix.mean(axis=0)[:2], 0.0)  # centred on the record mean
    assert ext.added == ("voltage[k]", "lowpass(voltage, tau=0.05)")  # the channel at delay 0 and its low-pass


@pytest.mark.parametrize("name", sorted(NO_EXTENSION))
def test_an_effect_without_extension_says_why_even_with_every_channel(name):
    m = record("with_acceleration")
    result = EFFECTS[name].extension(SPEC, m, np.arange(len(m)), DiagnosisSettings())
    assert isinstance(result, NoExtension) and NO_EXTENSION[name] in result.reason and result.effect == name


def test_selecting_effects_keeps_the_order_asked_and_refuses_unknown_names():
    assert [e.name for e in select_effects(("inertia", "gas_force"))] == ["inertia", "gas_force"]
    assert select_effects(None) == list(EFFECTS.values())
    with pytest.raises(DiagnosisError, match="unknown effect.*'viscosity'.*the library has seal_friction"):
        select_effects(("viscosity",))


@pytest.mark.parametrize(("effect", "variant"), CASES)
def test_added_features_equal_their_onnx_nodes_sample_by_sample(effect, variant):
    ext = extension_of(effect, variant)
    m = record(variant)
    assert ext.added and [n for n in ext.spec.feature_names if n not in ext.added] == SPEC.feature_names
    channels = {c: np.asarray(m[c][:FEATURE_SAMPLES]) for c in ext.spec.channels}
    numpy_features = ext.spec.features(channels, m.sample_period)
    onnx_features = run_feature_nodes(ext.spec, channels, m.sample_period)
    np.testing.assert_allclose(onnx_features, numpy_features, rtol=1e-12, atol=1e-12)
    added = [ext.spec.feature_names.index(n) for n in ext.added]
    assert np.all(np.std(numpy_features[:, added], axis=0) > 0)  # each added column varies: a real check


@pytest.mark.slow
@pytest.mark.parametrize(("effect", "variant"), CASES)
def test_the_exported_step_graph_of_an_extended_network_reproduces_its_numpy_prediction(
    effect, variant, tmp_path: Path
):
    ext = extension_of(effect, variant)
    m = record(variant)
    model = train_model(m, ext.spec, Architecture("mlp", (3,)), TrainSettings(max_epochs=3, restarts=1)).model
    path = tmp_path / f"{effect}.onnx"
    export_onnx(model, path)
    channels = {c: np.asarray(m[c]) for c in ext.spec.channels}
    replayed = run_step_graph(path, channels)["force"]
    np.testing.assert_allclose(replayed, model.predict(channels), rtol=1e-9, atol=1e-9 * np.max(np.abs(m["force"])))
