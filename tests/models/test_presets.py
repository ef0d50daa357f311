"""Presets reproduce the thesis networks; request overrides map onto spec, network and settings."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.errors import SettingsError
from nnfmu.models.features import FeatureSpec, Highpass, Lowpass, Tap
from nnfmu.models.presets import (
    FAST_MEMORY_TAUS,
    MEMORY_TAUS,
    PRESETS,
    TORSIONAL_MEMORY_TAUS,
    custom_spec,
    get_preset,
    memory_bank,
)
from nnfmu.models.train import TrainSettings
from nnfmu.workflows.train import TrainRequest, resolve


@pytest.mark.parametrize(
    ("name", "output", "n_in", "hidden"),
    [
        ("damper-spline", "force", 1, 3),
        ("bushing-axial-force", "axial_force", 2, 3),
        ("bushing-radial-force", "radial_force", 2, 3),
        ("bushing-axial-torque", "axial_torque", 4, 7),
        ("bushing-conical-torque", "conical_torque", 4, 7),
    ],
)
def test_thesis_network_sizes(name, output, n_in, hidden):
    preset = get_preset(name)
    assert preset.output == output and preset.thesis_spec.output == output
    assert preset.thesis_spec.n_features == n_in and not preset.thesis_spec.derived
    assert preset.thesis.kind == "mlp" and preset.thesis.hidden == (hidden,)
    # the default search starts at the thesis size and only tries larger nets
    assert preset.architecture.hidden[0] == hidden and len(preset.architecture.hidden) >= 2


def test_input_channels_follow_the_rig_names():
    assert get_preset("damper-spline").spec.taps == (Tap("velocity"),)
    for name, channels, taus in [
        ("bushing-axial-force", ["axial_displacement", "axial_velocity"], MEMORY_TAUS),
        ("bushing-radial-force", ["radial_displacement", "radial_velocity"], FAST_MEMORY_TAUS),
        ("bushing-axial-torque", ["axial_rotation", "axial_angular_velocity"], TORSIONAL_MEMORY_TAUS),
        ("bushing-conical-torque", ["conical_rotation", "conical_angular_velocity"], MEMORY_TAUS),
    ]:
        preset = get_preset(name)
        assert preset.thesis_spec.channels == channels and preset.spec.channels == channels
        # the default adds the high-pass memory bank of the position channel (denser where it gains)
        assert preset.spec.derived[: len(taus)] == tuple(Highpass(channels[0], tau=t) for t in taus)
        assert preset.spec.derived[len(taus)].kind != "highpass"
        assert preset.spec.taps == (Tap(channels[0]), Tap(channels[1]))
    assert get_preset("bushing-axial-torque").thesis_spec.taps == (
        Tap("axial_rotation", (0, 1)),
        Tap("axial_angular_velocity", (0, 1)),
    )
    hysteresis = get_preset("damper-hysteresis")
    assert hysteresis.thesis_spec.taps == (Tap("velocity", (0, 1)),) and hysteresis.thesis.hidden == (5,)
    assert hysteresis.spec.channels == ["velocity"] and hysteresis.output == "force"
    # the default's history enters as rates (differences) and fading memory (high-passes), not as delayed or
    # smoothed copies of the velocity
    assert hysteresis.spec.taps == (Tap("velocity"),)
    kinds = [d.kind for d in hysteresis.spec.derived]
    assert kinds == ["difference", "difference", "smooth_sign", "highpass", "highpass"]
    assert [d.kind for d in get_preset("damper-spline").spec.derived] == ["smooth_sign", "smooth_sign"]


def largest_correlation(spec: FeatureSpec, record) -> float:
    """Largest |correlation| between two different feature columns of `spec` over a rig record."""
    columns = spec.features({c: record[c] for c in spec.channels}, record.sample_period)
    correlation = np.abs(np.corrcoef(columns.T))
    np.fill_diagonal(correlation, 0.0)
    return float(correlation.max())


@pytest.fixture(scope="module")
def bushing_lab_record():
    """37 s of the bushing rig's lab record (seed 0: its stiffness series, then 10 s of random), shared by the
    memory-bank tests."""
    return simulate_rig("bushing", RigOptions(seed=0, duration=37.0)).measurement


def test_default_bushing_memory_is_not_collinear_with_the_position(bushing_lab_record):
    """The high-pass bank leaves no pair of inputs as collinear as the low-pass bank it replaced (nets that difference
    near-copies need large opposite weights)."""
    record = bushing_lab_record
    for name in ("bushing-axial-force", "bushing-radial-force", "bushing-axial-torque", "bushing-conical-torque"):
        spec = get_preset(name).spec
        position, rate = (t.channel for t in spec.taps)
        highpass_bank = FeatureSpec(spec.taps, spec.output, memory_bank(position))
        lowpass_bank = FeatureSpec(spec.taps, spec.output, tuple(Lowpass(position, tau=t) for t in MEMORY_TAUS))
        assert largest_correlation(highpass_bank, record) < min(0.9, largest_correlation(lowpass_bank, record))


def test_no_bushing_memory_branch_copies_the_rate(bushing_lab_record):
    """A high-pass whose corner lies far above the rig's band (1 ms: 160 Hz) is ~tau times the rate there (correlation
    0.98 on the lab record), so the record cannot split the two and the split sets the network's loss angle above the
    band (docs/passivity.md): the branches from 10 ms up have their corners inside the band (correlation under 0.9).
    The 3 ms branch (53 Hz, 0.92) is only in the radial and torsional presets, where the passivity check refused no
    more of the search's runs with it than without (with the decade bank: radial with the stops to 40 um, 2 of 45
    against 14; to 640 um, 6 of 45 either way; torsional, none of 27 either way; bench/passivity_runs.py)."""
    record = bushing_lab_record
    banks = {
        "bushing-axial-force": MEMORY_TAUS,
        "bushing-radial-force": FAST_MEMORY_TAUS,
        "bushing-axial-torque": TORSIONAL_MEMORY_TAUS,
        "bushing-conical-torque": MEMORY_TAUS,
    }
    for name, bank in banks.items():
        spec = get_preset(name).spec
        position, rate = (t.channel for t in spec.taps)
        highpasses = [d for d in spec.derived if d.kind == "highpass"]
        assert [h.tau for h in highpasses] == list(bank)
        for branch in highpasses:
            pair = FeatureSpec((Tap(position), Tap(rate)), spec.output, (branch,))
            columns = pair.features({c: record[c] for c in pair.channels}, record.sample_period)
            limit = 0.9 if branch.tau >= min(MEMORY_TAUS) else 0.95
            assert abs(np.corrcoef(columns[:, 1], columns[:, 2])[0, 1]) < limit, (name, branch.tau)


def test_default_damper_memory_is_not_collinear_with_the_velocity():
    """The hysteresis preset's fading memory enters as velocity high-passes: low-passes at the same time constants
    would be near-copies of the velocity itself on a dyno record."""
    record = simulate_rig("damper", RigOptions(seed=0, duration=10.0, excitation="random")).measurement
    spec = get_preset("damper-hysteresis").spec
    taus = [d.tau for d in spec.derived if d.kind == "highpass"]
    assert taus
    for tau in taus:
        lowpass = FeatureSpec(spec.taps, spec.output, (Lowpass("velocity", tau=tau),))
        highpass = FeatureSpec(spec.taps, spec.output, (Highpass("velocity", tau=tau),))
        assert largest_correlation(lowpass, record) > 0.95
        assert largest_correlation(highpass, record) < 0.5


def test_every_preset_is_listed_and_unknown_names_are_refused():
    assert set(PRESETS) == {
        "damper-spline",
        "damper-hysteresis",
        "bushing-axial-force",
        "bushing-radial-force",
        "bushing-axial-torque",
        "bushing-conical-torque",
        "damper-semiactive",
    }
    with pytest.raises(ValueError, match="damper-spline"):
        get_preset("damper")


def test_custom_inputs_delays_and_output():
    base = get_preset("damper-hysteresis").spec
    spec = custom_spec(base, output="force_filtered", inputs=("velocity", "displacement"), delays=(0, 2))
    assert spec.taps == (Tap("velocity", (0, 2)), Tap("displacement", (0, 2))) and spec.output == "force_filtered"
    assert not spec.derived  # the bank belongs to the preset's own inputs
    retapped = custom_spec(base, delays=(0, 1))
    assert retapped.taps == (Tap("velocity", (0, 1)),) and retapped.derived == base.derived
    assert custom_spec(base) == base


def test_request_overrides_network_and_settings():
    preset, architecture, settings = resolve(
        TrainRequest("damper-spline", hidden=(3, 5), restarts=1, seed=7, max_epochs=9)
    )
    assert architecture.hidden == (3, 5) and architecture.kind == "mlp"
    assert (settings.restarts, settings.seed, settings.max_epochs) == (1, 7, 9)
    _, thesis, _ = resolve(TrainRequest("bushing-axial-torque", thesis=True))
    assert thesis.hidden == (7,)
    _, gru, _ = resolve(TrainRequest("damper-hysteresis", recurrent=True))
    assert gru.kind == "gru" and gru.hidden
    with pytest.raises(ValueError, match="optimizer"):
        resolve(TrainRequest("damper-spline", optimizer="sgd"))


def test_bushing_presets_train_on_low_passed_inputs_and_a_request_can_change_it():
    assert {
        name: p.settings.input_cutoff for name, p in PRESETS.items() if name.startswith("bushing")
    } == dict.fromkeys(
        ("bushing-axial-force", "bushing-radial-force", "bushing-axial-torque", "bushing-conical-torque"), 100.0
    )
    assert all(p.settings.input_cutoff is None for name, p in PRESETS.items() if name.startswith("damper"))
    assert resolve(TrainRequest(preset="bushing-axial-torque"))[2].input_cutoff == 100.0
    assert resolve(TrainRequest(preset="bushing-axial-torque", input_cutoff=0.0))[2].input_cutoff is None
    assert resolve(TrainRequest(preset="damper-hysteresis", input_cutoff=80.0))[2].input_cutoff == 80.0
    with pytest.raises(SettingsError, match="input_cutoff must be a positive frequency"):
        TrainSettings(input_cutoff=-5.0)


def test_the_thesis_network_trains_as_trainlm_did_and_the_default_in_its_presets_coordinates():
    assert {p.settings.lm_inputs for p in PRESETS.values()} > {"raw"}  # some default steps elsewhere
    for name, preset in PRESETS.items():
        default, thesis = (resolve(TrainRequest(name, thesis=t, seed=3))[2] for t in (False, True))
        assert default.lm_inputs == preset.settings.lm_inputs and thesis.lm_inputs == "raw"
        assert replace(thesis, lm_inputs=default.lm_inputs) == default  # nothing else differs
