"""A campaign's `[coupling] engine`: "compiled" runs each case as its variant's cached system FMU with the same scores
as the Python engine, names its cases apart from the Python engine's (whose keys stay as before engines existed),
and is refused with settings its system FMU cannot step."""

from __future__ import annotations

import pytest
from campaign_helpers import campaign_text, read_rows, write_campaign

from nnfmu.workflows.campaign import CampaignError, read_campaign, run_campaign
from nnfmu.workflows.campaign.cases import case_key, expand_cases

SCORES = ("rms", "peak", "valley", "damage")


def test_the_compiled_engine_scores_a_campaign_as_the_python_engine(quarter_car, tmp_path):
    one = {"events": 2, "variants": ("firm",)}  # one system FMU to build
    python = write_campaign(tmp_path / "python", campaign_text(quarter_car, **one))
    compiled = write_campaign(
        tmp_path / "compiled", campaign_text(quarter_car, **one, coupling='step = 1e-3\nengine = "compiled"')
    )
    for path in (python, compiled):
        run = run_campaign(path, path.parent / "out", workers=0)
        assert run.ok == run.cases == 2
    reference, result = read_rows(python.parent / "out"), read_rows(compiled.parent / "out")
    assert [(r["event"], r["variant"], r["channel"], r["unit"]) for r in result] == [
        (r["event"], r["variant"], r["channel"], r["unit"]) for r in reference
    ]
    for got, want in zip(result, reference):
        for column in SCORES:
            assert got[column] == pytest.approx(want[column], rel=1e-12, abs=1e-300), (got, column)
    assert max(abs(r["peak"]) for r in result if r["channel"] == "damper_force") > 10.0  # [N] the cases did work
    cases = {c.key for c in expand_cases(read_campaign(compiled))}
    assert cases.isdisjoint(r["case"] for r in reference)  # another engine: other parts


def test_the_python_engines_case_keys_are_those_without_an_engine(quarter_car, tmp_path):
    campaign = read_campaign(write_campaign(tmp_path, campaign_text(quarter_car, events=1)))
    assert campaign.engine == "python"
    resolved = campaign.resolved_coupling()
    for case in expand_cases(campaign):
        assert case.key == case_key(case.event, case.variant, resolved, case.metrics)
        assert case.key != case_key(case.event, case.variant, resolved, case.metrics, "compiled")


@pytest.mark.parametrize(
    "coupling, words",
    [
        ('engine = "turbo"', ["[coupling]", "engine 'turbo'", "python, compiled"]),
        ('engine = "compiled"\niterations = 2', ["[coupling]", "one-pass schemes only", "iterations 2"]),
        ('engine = "compiled"\nextrapolation = "none"', ["[coupling]", "extrapolation 'none'"]),
    ],
)
def test_an_engine_it_cannot_use_is_refused_naming_the_key(quarter_car, tmp_path, coupling, words):
    with pytest.raises(CampaignError) as caught:
        read_campaign(write_campaign(tmp_path, campaign_text(quarter_car, coupling=f"step = 1e-3\n{coupling}")))
    for word in words:
        assert word in str(caught.value)
