"""The dyno's moving mass estimated from a damper record (issue 29, item 4): the dyno simulator's lab record with its
2 kg fixture and without it; `nnfmu train` reports the estimate and takes the mass out at defaults and with
`--moving-mass auto` (issue 28: the user's default path in a car), keeps the force with `--moving-mass 0`."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.data import Measurement, save_measurement
from nnfmu.data.moving_mass import estimate_moving_mass
from nnfmu.data.rigs import DamperParams, RigOptions, simulate_rig

WITHOUT_FIXTURE = ("hysteresis", "seal_friction")  # the damper default without "inertia"
runner = CliRunner()


def _dyno(effects: tuple[str, ...] | None) -> Measurement:
    """40 s of the dyno's lab program (sine series, then random), the rig's sensor noise."""
    return simulate_rig("damper", RigOptions(duration=40.0, seed=3, effects=effects)).measurement


@pytest.fixture(scope="module")
def with_fixture() -> Measurement:
    return _dyno(None)  # the default effects carry the fixture's 2 kg


@pytest.mark.slow
def test_a_two_kg_fixture_is_found_within_ten_percent(with_fixture: Measurement) -> None:
    estimate = estimate_moving_mass(with_fixture)
    truth = DamperParams().moving_mass
    assert truth == 2.0
    assert abs(estimate.mass - truth) < 0.1 * truth, estimate
    assert 0 < estimate.half_width < 0.1 * truth
    assert estimate.found and estimate.share > 0.03  # m·a is a few per cent of this record's force rms
    assert "± 0.0" in estimate.describe() and "kg (95 %)" in estimate.describe()


@pytest.mark.slow
def test_no_fixture_gives_zero_within_its_confidence() -> None:
    estimate = estimate_moving_mass(_dyno(WITHOUT_FIXTURE))
    assert abs(estimate.mass) <= estimate.half_width < 0.05, estimate
    assert not estimate.found


@pytest.mark.slow
def test_train_takes_the_mass_out_at_defaults_and_auto_and_keeps_it_at_zero(
    with_fixture: Measurement, tmp_path: Path
) -> None:
    data = save_measurement(with_fixture, tmp_path / "dyno.csv")
    tiny = ["--preset", "damper-spline", "--max-epochs", "2", "--restarts", "1", "--hidden", "2"]
    for option in ([], ["--moving-mass", "auto"]):
        run = runner.invoke(app, ["train", str(data), "--out", str(tmp_path / "m.onnx"), *option, *tiny])
        assert run.exit_code == 0, run.output
        text = " ".join(run.output.split())  # rich wraps long lines
        estimated = re.search(
            r"note: moving mass between load cell and actuator estimated from the record: ([\d.]+)", text
        )
        compensated = re.search(r"note: force compensated for ([\d.]+) kg of moving mass", text)
        assert estimated and compensated, text
        assert abs(float(estimated[1]) - 2.0) < 0.1 and abs(float(compensated[1]) - 2.0) < 0.1  # the 2 kg fixture
        assert ("--moving-mass 0 trains the force as measured" in text) == (not option)
        assert "warning:" not in text
    kept = runner.invoke(app, ["train", str(data), "--out", str(tmp_path / "k.onnx"), "--moving-mass", "0", *tiny])
    assert kept.exit_code == 0, kept.output
    assert "compensated for" not in " ".join(kept.output.split())
    bad = runner.invoke(app, ["train", str(data), "--out", str(tmp_path / "x.onnx"), "--moving-mass", "heavy", *tiny])
    assert bad.exit_code == 2
    assert "give a mass in kg (e.g. 2.0) or auto, not 'heavy'" in " ".join(bad.output.replace("│", " ").split())


@pytest.mark.slow
def test_a_record_without_a_fixture_is_trained_as_measured_at_defaults(tmp_path: Path) -> None:
    data = save_measurement(_dyno(WITHOUT_FIXTURE), tmp_path / "dyno.csv")
    tiny = ["--preset", "damper-spline", "--max-epochs", "2", "--restarts", "1", "--hidden", "2"]
    run = runner.invoke(app, ["train", str(data), "--out", str(tmp_path / "m.onnx"), *tiny])
    assert run.exit_code == 0, run.output
    text = " ".join(run.output.split())
    assert "note: moving mass between load cell and actuator estimated from the record" in text
    assert "compensated for" not in text and "warning:" not in text


def test_the_estimate_holds_no_design_of_the_records_length(
    with_fixture: Measurement, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On 10 M rows `nnfmu train` reached 8.9 GB in the estimate (its 25-column design held several times over): the
    normal equations are summed by parts (here 2048 rows, so that the 40 s record has 20), so the peak stays below
    one design of the record's length, and the estimate is unchanged."""
    import tracemalloc

    import nnfmu.data.moving_mass as moving_mass

    monkeypatch.setattr(moving_mass, "ROWS", 2048)
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        before, _ = tracemalloc.get_traced_memory()
        estimate = estimate_moving_mass(with_fixture)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    design = len(with_fixture) * 25 * 8
    assert peak - before < 0.7 * design, (peak - before, design)
    assert abs(estimate.mass - DamperParams().moving_mass) < 0.1 * DamperParams().moving_mass, estimate
