"""The vehicle loop's attribution on synthetic residuals: one physical cause before several offsets (an information
criterion charging each fitted parameter), a genuine single-channel offset stays an offset, and every named candidate
says why it beat its rivals."""

from __future__ import annotations

import numpy as np

from nnfmu.export.terms import OutputTerm
from nnfmu.workflows.vehicle_loop.attribution import (
    Candidate,
    Selection,
    attribute,
    offset_candidate,
    one_cause,
)
from nnfmu.workflows.vehicle_loop.attribution import _stack as stack

N = 2000
CHANNELS = ["damper_displacement", "damper_force", "body_acceleration"]


def _columns(pattern: tuple[float, float, float], motion: float = 0.0) -> np.ndarray:
    """An (n, C) sensitivity: a constant per channel, plus a swing on the last channel of amplitude `motion`."""
    t = np.arange(N) * 1e-3
    column = np.tile(np.asarray(pattern, dtype=float), (N, 1))
    column[:, 2] += motion * np.sin(2 * np.pi * 3 * t)
    return column


def _problem(shift: tuple[float, float, float], physical: dict[str, np.ndarray]):
    """A residual of constant shifts plus noise; an offset candidate per channel and the given physical ones."""
    rng = np.random.default_rng(3)
    residual = np.asarray(shift) + 0.05 * rng.standard_normal((N, 3))
    candidates = {offset_candidate(c).key: offset_candidate(c) for c in CHANNELS}
    columns = {key: [np.eye(3)[i] * np.ones((N, 1))] for i, key in enumerate(candidates)}
    for key, column in physical.items():
        element, effect = key.split(":")
        candidates[key] = Candidate(element, effect, (OutputTerm("force", None, -100.0, "N"),))
        columns[key] = [column]
    return residual, candidates, columns


def test_one_physical_cause_replaces_two_offsets_that_it_explains() -> None:
    """The gas force's pattern (corner lower, load cell up) fits both shifts with one coefficient: two offsets named
    for them give way to it, and the reason names both and the criterion."""
    residual, candidates, columns = _problem((-0.8, 0.4, 0.0), {"damper:gas_force": _columns((-0.8, 0.4, 0.0))})
    target = residual.ravel(order="F")
    designs = {k: stack(v) for k, v in columns.items()}
    fold = np.tile(np.arange(N) % 100 < 50, 3)
    selection = Selection(target, designs, fold, N, 0.01, 0.005, 3)
    why: dict[str, str] = {}
    offsets = ["damper_displacement:sensor_offset", "damper_force:sensor_offset"]
    story, replaced = one_cause(offsets, candidates, selection, why)
    assert replaced and story == ["damper:gas_force"]
    assert why["damper:gas_force"].startswith("physical causes before offsets: damper:gas_force first, then no offset")
    assert "in place of damper_displacement:sensor_offset then damper_force:sensor_offset" in why["damper:gas_force"]


def test_a_physical_cause_that_predicts_motion_nobody_measured_does_not_replace_offsets() -> None:
    """The same shifts, but the only physical candidate would also swing the body: the offsets stay."""
    swinging = _columns((-0.8, 0.4, 0.0), motion=1.0)
    residual, candidates, columns = _problem((-0.8, 0.4, 0.0), {"damper:gas_force": swinging})
    target = residual.ravel(order="F")
    designs = {k: stack(v) for k, v in columns.items()}
    fold = np.tile(np.arange(N) % 100 < 50, 3)
    offsets = ["damper_displacement:sensor_offset", "damper_force:sensor_offset"]
    story, replaced = one_cause(offsets, candidates, Selection(target, designs, fold, N, 0.01, 0.005, 3), {})
    assert not replaced and story == offsets


def test_attribution_names_the_cause_or_the_genuine_offset_and_says_why() -> None:
    pattern = _columns((-0.8, 0.4, 0.0))
    residual, candidates, columns = _problem((-0.8, 0.4, 0.0), {"damper:gas_force": pattern})
    found = attribute(residual, CHANNELS, columns, candidates, 20, 0.01, 0.005, 3)
    assert [e.candidate.key for e in found.named] == ["damper:gas_force"]
    why = found.named[0].why
    assert why.startswith("explained ") and "BIC" in why and "damper_displacement:sensor_offset" in why

    residual, candidates, columns = _problem((0.0, 0.4, 0.0), {"damper:gas_force": pattern})  # load cell only
    found = attribute(residual, CHANNELS, columns, candidates, 20, 0.01, 0.005, 3)
    assert [e.candidate.key for e in found.named] == ["damper_force:sensor_offset"]


def test_a_cause_and_an_offset_the_channels_cannot_place_are_both_named_and_the_tie_is_said() -> None:
    """Gas force and a load-cell offset at once: with one deflection channel the statics hold two numbers for three
    knobs (preload, force offset, stroke offset), so after the gas force either offset completes the story; the
    loop names the gas force and an offset, and says which offset it cannot tell from the other."""
    residual, candidates, columns = _problem((-0.8, 1.3, 0.0), {"damper:gas_force": _columns((-0.8, 0.4, 0.0))})
    found = attribute(residual, CHANNELS, columns, candidates, 20, 0.01, 0.005, 3)
    named = [e.candidate.key for e in found.named]
    assert "damper:gas_force" in named and len(named) == 2
    (offset,) = [e for e in found.named if e.candidate.effect == "sensor_offset"]
    other = ({"damper_force:sensor_offset", "damper_displacement:sensor_offset"} - {offset.candidate.key}).pop()
    assert other in offset.alike  # in its place the other offset tells the same story


def test_an_offset_that_only_cancels_a_causes_side_effect_does_not_make_the_story() -> None:
    """A load-cell offset, and a small model error on the force that the gas force's rate term happens to fit (too
    small to name the gas force beyond the offset, enough to lower a story's BIC). Physical first, the gas preload
    needs a stroke-sensor offset to cancel the corner lift it predicts, an offset that explains nothing by itself,
    or the load-cell offset, beyond which the gas force adds too little: the named load-cell offset stays."""
    t = np.arange(N) * 1e-3
    wobble = np.sin(2 * np.pi * 3 * t)
    residual, candidates, columns = _problem((0.0, 0.4, 0.0), {})
    residual[:, 1] += 0.008 * wobble  # the network's own error, shaped like the rate term
    candidates["damper:gas_force"] = Candidate("damper", "gas_force", (OutputTerm("force", None, -100.0, "N"),) * 2)
    rate = np.zeros((N, 3))
    rate[:, 1] = wobble
    columns["damper:gas_force"] = [_columns((-0.8, 0.4, 0.0)), rate]
    designs = {k: stack(v) for k, v in columns.items()}
    fold = np.tile(np.arange(N) % 100 < 50, 3)
    selection = Selection(residual.ravel(order="F"), designs, fold, N, 0.01, 0.005, 3)
    assert selection.explains_beyond(["damper:gas_force"], "damper_displacement:sensor_offset")  # it cancels the lift
    assert not selection.explains_beyond([], "damper_displacement:sensor_offset")  # and explains nothing alone
    assert not selection.explains_beyond(["damper_force:sensor_offset"], "damper:gas_force")
    assert (
        selection.bic(["damper:gas_force", "damper_displacement:sensor_offset"])
        < selection.bic(["damper_force:sensor_offset"]) - 2
    )
    named = ["damper_force:sensor_offset"]
    story, replaced = one_cause(named, candidates, selection, {})
    assert not replaced and story == named
