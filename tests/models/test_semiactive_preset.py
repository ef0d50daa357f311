"""The damper-semiactive preset: its command placeholder binds to the record's voltage or current channel, its
command low-pass time constants are chosen by validation error, and it trains as a perceptron or a GRU."""

from __future__ import annotations

import pytest

from nnfmu.data.errors import DataError
from nnfmu.data.rigs import RigOptions, write_rig
from nnfmu.models.features import Lowpass, Tap
from nnfmu.models.presets import COMMAND, SEMIACTIVE_COMMAND_TAUS, bind_command, get_preset
from nnfmu.workflows.train import TrainRequest, train_from_file

TINY = dict(hidden=(3,), restarts=1, max_epochs=3)


@pytest.fixture(scope="module")
def mr_record(tmp_path_factory) -> str:
    """A short noisy MR dyno record: random stroke and command."""
    out = tmp_path_factory.mktemp("semiactive") / "mr.csv"
    write_rig("damper", out, RigOptions(damper_type="mr", duration=6.0, excitation="random", seed=2))
    return str(out)


def test_the_preset_reads_velocity_displacement_and_the_command_with_its_dynamics():
    preset = get_preset("damper-semiactive")
    assert preset.output == "force" and preset.spec.channels == ["velocity", "displacement", COMMAND]
    lowpasses = [{d.tau for d in spec.derived if isinstance(d, Lowpass)} for spec in preset.candidates]
    assert sorted(lowpasses, key=min) == [set(taus) for taus in SEMIACTIVE_COMMAND_TAUS]
    assert all(Tap(COMMAND, (0, 10)) in spec.taps for spec in preset.candidates)
    assert Tap(COMMAND, (0, 3, 10, 30)) in preset.thesis_spec.taps


@pytest.mark.parametrize("channel", ["voltage", "current"])
def test_the_command_binds_to_the_records_channel(channel):
    spec = bind_command(get_preset("damper-semiactive").spec, ["velocity", "displacement", channel, "force"], "r.csv")
    assert spec.channels == ["velocity", "displacement", channel]
    assert {d.channel for d in spec.derived if isinstance(d, Lowpass)} == {channel}


@pytest.mark.parametrize(("channels", "problem"), [(["velocity"], "has none of"), (["voltage", "current"], "has both")])
def test_a_record_without_one_command_channel_is_refused_by_name(channels, problem):
    with pytest.raises(DataError, match=f"r.csv: .*voltage \\[V\\].*current \\[A\\].*the record {problem} them"):
        bind_command(get_preset("damper-semiactive").spec, channels, "r.csv")


def test_training_chooses_the_command_time_constants_by_validation(mr_record, tmp_path):
    outcome = train_from_file(mr_record, TrainRequest("damper-semiactive", **TINY), tmp_path / "mr.onnx")
    model = outcome.model
    assert model.spec.channels == ["velocity", "displacement", "voltage"]
    assert model.units["voltage"] == "V" and model.units["force"] == "N"
    scores = outcome.feature_choice
    assert len(scores) == len(SEMIACTIVE_COMMAND_TAUS)
    best = min(scores, key=lambda pair: pair[1])
    assert model.spec == best[0]
    assert outcome.export.max_relative_error <= 1e-6


@pytest.mark.slow
def test_recurrent_option_trains_a_gru_on_the_command(mr_record, tmp_path):
    request = TrainRequest("damper-semiactive", recurrent=True, hidden=(4,), restarts=1, max_epochs=2)
    outcome = train_from_file(mr_record, request, tmp_path / "mr_gru.onnx")
    assert outcome.model.settings["kind"] == "gru" and "voltage" in outcome.model.spec.channels
    assert outcome.feature_choice == []  # the GRU's own state holds the command's dynamics


def test_a_passive_record_is_refused_with_the_channels_named(tmp_path):
    data, _ = write_rig("damper", tmp_path / "passive.csv", RigOptions(duration=3.0, excitation="random"))
    with pytest.raises(DataError, match="passive.csv: a semi-active damper model needs one command channel"):
        train_from_file(data, TrainRequest("damper-semiactive", **TINY), tmp_path / "x.onnx")
    assert not (tmp_path / "x.onnx").exists()
