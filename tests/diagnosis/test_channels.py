"""Measured channels the model does not use as candidate effects (`input:<channel>`): which channels become
candidates, and the diagnosis of a velocity-only network on a magnetorheological damper record (the coil voltage
ranks first and significant) and on a passive damper record with an unrelated random voltage beside it (not
significant)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from nnfmu.data import Measurement
from nnfmu.data.rigs import RigOptions, simulate_rig
from nnfmu.diagnosis import (
    EFFECTS,
    ChannelInput,
    DiagnosisError,
    DiagnosisSettings,
    channel_effects,
    diagnose,
    effects_for,
    find_effect,
)
from nnfmu.models import Architecture, TrainSettings, get_preset, train_model

SPEC = get_preset("damper-hysteresis").spec  # velocity, its differences, the friction sign: no command
DURATION = 12.0  # s of random drive at 1 kHz


@cache
def record(damper_type: str) -> Measurement:
    """A random-drive damper record; the passive one gets a random coil voltage (0-5 V, steps of 0.1 s) that does
    nothing to the force."""
    m = simulate_rig(
        "damper", RigOptions(duration=DURATION, seed=1, damper_type=damper_type, excitation="random", noise=0.5)
    ).measurement
    if damper_type != "passive":
        return m
    steps = np.random.default_rng(5).uniform(0.0, 5.0, len(m) // 100 + 1)
    return Measurement(
        m.time,
        {**m.channels, "voltage": np.repeat(steps, 100)[: len(m)]},
        {**m.units, "voltage": "V"},
        f"{m.source} (unrelated voltage)",
    )


@cache
def diagnosis_of(damper_type: str):
    """A small velocity-history network fitted on the first half, diagnosed on the second."""
    m = record(damper_type)
    half = len(m) // 2
    model = train_model(
        m.slice(0, half), SPEC, Architecture("mlp", (6,)), TrainSettings(max_epochs=100, restarts=1)
    ).model
    predicted = model.predict({c: m[c] for c in SPEC.channels})
    rest = m.slice(half, len(m))
    return diagnose(rest, predicted[half:], "force", SPEC.channels)


def test_candidates_are_the_channels_no_effect_covers():
    m = record("mr")
    assert [e.name for e in channel_effects(m, ("velocity",), "force")] == ["input:voltage"]
    assert channel_effects(m, ("velocity", "voltage"), "force") == []  # a model input is no candidate
    units = {**m.units, "temperature": "K", "pressure": "Pa", "radial_force": "N", "axial_acceleration": "m/s^2"}
    more = Measurement(
        m.time, {**m.channels, **{k: m["voltage"] for k in units if k not in m.channels}}, units, "more channels"
    )
    # motion, loads and temperature belong to the physical families; the pressure is a candidate
    assert [e.name for e in channel_effects(more, ("velocity",), "force")] == ["input:voltage", "input:pressure"]


def test_the_run_merges_the_library_and_the_records_candidates_and_looks_either_up_by_name():
    m = record("mr")
    every = effects_for(m, ("velocity",), "force", None)
    assert [e.name for e in every] == [*EFFECTS, "input:voltage"]
    assert [e.name for e in effects_for(m, ("velocity",), "force", ("input:voltage", "inertia"))] == [
        "input:voltage",
        "inertia",
    ]
    with pytest.raises(DiagnosisError, match=r"'input:current'.*channel candidates input:voltage"):
        effects_for(m, ("velocity",), "force", ("input:current",))
    assert isinstance(find_effect("input:voltage"), ChannelInput) and find_effect("inertia") is EFFECTS["inertia"]
    with pytest.raises(DiagnosisError, match="unknown effect"):
        find_effect("input:")


def test_the_command_of_an_mr_damper_ranks_first_and_significant():
    d = diagnosis_of("mr")
    top = d.ranking[0]
    assert top.name == "input:voltage" and top.significant
    assert top.additional_explained_variance > 0.5  # the coil voltage scales most of the force
    assert d.summary.startswith("missing effect(s), in order of evidence: input:voltage")


def test_an_unrelated_channel_is_not_significant():
    d = diagnosis_of("passive")
    (voltage,) = [e for e in d.ranking if e.name == "input:voltage"]
    assert voltage.testable and not voltage.significant
    assert voltage.p_value > DiagnosisSettings().alpha / sum(e.testable for e in d.ranking)  # family-wise
