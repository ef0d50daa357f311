"""Campaign files: every bad key or value is refused naming the file, the entry and the key; cases are named by the
content of their inputs."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from campaign_helpers import campaign_text, write_campaign

from nnfmu.workflows.campaign import CampaignError, read_campaign
from nnfmu.workflows.campaign.cases import expand_cases


def _keys(path: Path) -> dict[tuple[str, str], str]:
    return {(c.event.name, c.variant.name): c.key for c in expand_cases(read_campaign(path))}


def test_a_campaign_expands_to_events_times_variants_with_seeds_per_repeat(quarter_car, tmp_path):
    campaign = read_campaign(write_campaign(tmp_path, campaign_text(quarter_car, events=3)))
    assert [e.name for e in campaign.events] == ["C-20#0", "C-20#1", "C-20#2"]
    assert [e.generator["seed"] for e in campaign.events] == [0, 1, 2]
    assert all(e.generator["duration"] == 1.0 and e.generator["road_class"] == "C" for e in campaign.events)
    cases = expand_cases(campaign)
    assert len(cases) == 6 and len({c.key for c in cases}) == 6
    firm = next(v for v in campaign.variants if v.name == "firm")
    damper = next(e for e in firm.elements if e.name == "damper")
    assert campaign.blobs[damper.fmu.sha256] == quarter_car["firm"].read_bytes()
    assert damper.parameters == {"filter_cutoff": 0.0}  # the base system's value, kept through the swap


@pytest.mark.parametrize(
    "section, line, words",
    [
        ("coupling", "bogus_setting = 1", ["[coupling]", "bogus_setting"]),
        ("coupling", 'scheme = "leapfrog"', ["[coupling]", "leapfrog"]),
        ("metrics", "basquin_slope = -2", ["[metrics]", "basquin_slope"]),
        ("metrics", "basquin_slope = 1e308", ["[metrics]", "basquin_slope", "1e+308", "(0, 50]"]),
        ("metrics", "colour = 1", ["[metrics]", "colour"]),
        ("drive", "wheel_count = 4", ["[drive]", "wheel_count"]),
    ],
)
def test_bad_settings_are_refused_naming_the_key(quarter_car, tmp_path, section, line, words):
    text = campaign_text(quarter_car).replace(f"[{section}]\n", f"[{section}]\n{line}\n")
    with pytest.raises(CampaignError) as caught:
        read_campaign(write_campaign(tmp_path, text))
    assert str(tmp_path / "campaign.toml") in str(caught.value)
    for word in words:
        assert word in str(caught.value)


def test_coupling_settings_pass_through_by_field_name(quarter_car, tmp_path):
    text = campaign_text(quarter_car, coupling='step = 2e-3\nscheme = "jacobi"\nextrapolation = "linear"')
    campaign = read_campaign(write_campaign(tmp_path, text))
    assert campaign.coupling == {"step": 2e-3, "scheme": "jacobi", "extrapolation": "linear"}
    assert campaign.resolved_coupling()["iterations"] == 0


@pytest.mark.parametrize(
    "extra, words",
    [
        ('[[events]]\nname = "x"\nclass = "C"\nwobble = 3', ["event 'x'", "wobble"]),
        ('[[events]]\nname = "x"\nclass = "Q"', ["event 'x'", "'Q'"]),
        ('[[events]]\nname = "x"\npotholes = [{ time = 0.5, diameter = 1.0 }]', ["potholes[0]", "diameter"]),
        ('[[events]]\nname = "x"\npotholes = [{ time = 0.999, depth = 0.05 }]', ["event 'x'", "rear axle"]),
        ('[[events]]\nname = "x"\ndrive = "missing.csv"', ["event 'x'", "missing.csv", "does not exist"]),
        ('[[events]]\nname = "C-20#1"\nclass = "C"', ["used twice", "C-20#1"]),
    ],
)
def test_bad_events_are_refused_naming_the_event_and_key(quarter_car, tmp_path, extra, words):
    with pytest.raises(CampaignError) as caught:
        read_campaign(write_campaign(tmp_path, campaign_text(quarter_car, extra_events=extra)))
    for word in words:
        assert word in str(caught.value)


def test_a_drive_file_event_takes_no_repeats(quarter_car, tmp_path):
    (tmp_path / "d.csv").write_text("time [s],actuator_fl_displacement [m]\n0,0\n")
    extra = '[[events]]\nname = "file"\ndrive = "d.csv"\nrepeats = 2'
    with pytest.raises(CampaignError, match="event 'file'.*repeats"):
        read_campaign(write_campaign(tmp_path, campaign_text(quarter_car, extra_events=extra)))


def test_bad_variants_are_refused_naming_the_variant_and_element(quarter_car, tmp_path):
    text = campaign_text(quarter_car).replace("fmus = { damper", "fmus = { spring", 1)
    with pytest.raises(CampaignError, match="variant 'linear'.*no element 'spring'"):
        read_campaign(write_campaign(tmp_path, text))
    text = campaign_text(quarter_car) + "parameters = { damper = { no_such_parameter = 1.0 } }\n"
    with pytest.raises(CampaignError, match="variant 'firm'.*no_such_parameter"):
        read_campaign(write_campaign(tmp_path, text))
    text = campaign_text(quarter_car).replace('reference = "linear"', 'reference = "stiff"')
    with pytest.raises(CampaignError, match="reference variant 'stiff'"):
        read_campaign(write_campaign(tmp_path, text))
    text = campaign_text(quarter_car).replace(
        f'fmus = {{ damper = "{quarter_car["firm"]}" }}', f'fmus = {{ damper = "{quarter_car["vehicle"]}" }}'
    )
    with pytest.raises(CampaignError, match="variant 'firm'.*damper"):  # the vehicle FMU has no velocity input
        read_campaign(write_campaign(tmp_path, text))


def test_case_keys_follow_the_content_of_the_inputs(quarter_car, tmp_path):
    """Same inputs, same keys (also from another folder); a changed FMU byte, setting or drive changes exactly the
    cases that depend on it."""
    first = _keys(write_campaign(tmp_path / "a", campaign_text(quarter_car)))
    assert _keys(write_campaign(tmp_path / "b", campaign_text(quarter_car))) == first
    stepped = _keys(write_campaign(tmp_path / "c", campaign_text(quarter_car, coupling="step = 2e-3")))
    assert all(stepped[k] != first[k] for k in first)
    longer = _keys(write_campaign(tmp_path / "d", campaign_text(quarter_car, duration=1.5)))
    assert all(longer[k] != first[k] for k in first)
    copy = dict(quarter_car)
    copy["firm"] = tmp_path / "firm-copy.fmu"
    shutil.copyfile(quarter_car["firm"], copy["firm"])
    assert _keys(write_campaign(tmp_path / "e", campaign_text(copy))) == first  # same bytes elsewhere: same cases
    copy["firm"] = quarter_car["unstable"]
    swapped = _keys(write_campaign(tmp_path / "f", campaign_text(copy)))
    assert {k for k in first if swapped[k] != first[k]} == {k for k in first if k[1] == "firm"}


def test_a_campaign_nested_too_deeply_is_refused_naming_the_file(tmp_path):
    """tomllib recurses per nested array: 100 000 of them were a RecursionError traceback."""
    path = tmp_path / "deep.toml"
    path.write_text("name = " + "[" * 100_000 + "\n", encoding="utf-8")
    with pytest.raises(CampaignError, match=r"deep\.toml.*nested too deeply"):
        read_campaign(path)


def _outside_fmu(quarter_car, tmp_path: Path) -> Path:
    """A working damper FMU two folders above the campaign's (`tmp_path/a/b/campaign.toml`)."""
    evil = tmp_path / "evil.fmu"
    shutil.copyfile(quarter_car["firm"], evil)
    return evil


@pytest.mark.parametrize(
    "change, words",
    [
        (
            lambda text, qc: text + '[[events]]\nname = "secret"\ndrive = "/etc/passwd"\n',
            ["event 'secret'", "/etc/passwd"],
        ),
        (
            lambda text, qc: text.replace(f'damper = "{qc["firm"]}"', 'damper = "../../evil.fmu"'),
            ["variant 'firm'", "fmus.damper", "evil.fmu"],
        ),
        (lambda text, qc: text + '[[events]]\nname = "link"\ndrive = "link.csv"\n', ["event 'link'", "link.csv"]),
    ],
    ids=["absolute drive", "variant FMU two folders up", "link leading out"],
)
def test_a_path_outside_the_campaign_folder_is_refused_unless_allowed(quarter_car, tmp_path, change, words):
    _outside_fmu(quarter_car, tmp_path)
    (tmp_path / "outside.csv").write_text("time [s],actuator_fl_displacement [m]\n0,0\n0.001,0\n")
    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "a" / "b" / "link.csv").symlink_to(tmp_path / "outside.csv")
    path = write_campaign(tmp_path / "a" / "b", change(campaign_text(quarter_car), quarter_car))
    with pytest.raises(CampaignError) as caught:
        read_campaign(path)
    for word in words + ["outside", "--allow-outside"]:
        assert word in str(caught.value), caught.value
    assert read_campaign(path, allow_outside=True).variants  # the opt-in reads it


def test_a_campaign_with_every_file_inside_its_folder_needs_no_opt_in(quarter_car, tmp_path):
    shutil.copyfile(quarter_car["firm"], tmp_path / "firm.fmu")
    text = campaign_text(quarter_car).replace(f'damper = "{quarter_car["firm"]}"', 'damper = "firm.fmu"')
    campaign = read_campaign(write_campaign(tmp_path, text))
    assert [v.name for v in campaign.variants] == ["linear", "firm"]


def test_a_campaign_past_the_case_limit_is_refused_before_any_case_is_made(quarter_car, tmp_path):
    import time

    from nnfmu.workflows.campaign.spec import MAX_CASES

    text = campaign_text(quarter_car).replace("repeats = 3", "repeats = 1000000000")
    started = time.monotonic()
    with pytest.raises(CampaignError, match=rf"event 'C-20'.*1000000000.*{MAX_CASES}"):
        read_campaign(write_campaign(tmp_path / "a", text))
    text = campaign_text(quarter_car).replace("repeats = 3", f"repeats = {MAX_CASES // 2 + 1}")  # x 2 variants
    with pytest.raises(CampaignError, match=rf"{MAX_CASES}"):
        read_campaign(write_campaign(tmp_path / "b", text))
    assert time.monotonic() - started < 5


def test_twenty_thousand_repeats_are_read_in_linear_time(quarter_car, tmp_path):
    """Each repeat's name was checked against every other (20 000 repeats: 15 s); now a count per name."""
    import time

    campaign = read_campaign(write_campaign(tmp_path / "small", campaign_text(quarter_car, events=2000)))
    started = time.monotonic()
    read_campaign(write_campaign(tmp_path / "small", campaign_text(quarter_car, events=2000)))
    small = time.monotonic() - started
    started = time.monotonic()
    large = read_campaign(write_campaign(tmp_path / "large", campaign_text(quarter_car, events=20000)))
    ten_times = time.monotonic() - started
    assert len(campaign.events) == 2000 and len(large.events) == 20000
    assert ten_times < 25 * small + 1.0, (small, ten_times)  # linear: ~10x (quadratic: ~100x)


@pytest.mark.parametrize("device", ["/dev/zero", "fifo"])
def test_a_drive_that_is_not_a_regular_file_is_refused_before_hashing(quarter_car, tmp_path, device):
    if device == "fifo":
        os.mkfifo(tmp_path / "drive.csv")
        drive = "drive.csv"
    else:
        drive = device
    extra = f'[[events]]\nname = "endless"\ndrive = "{drive}"'
    with pytest.raises(CampaignError, match="event 'endless'.*not a regular file"):
        read_campaign(write_campaign(tmp_path, campaign_text(quarter_car, extra_events=extra)), allow_outside=True)
