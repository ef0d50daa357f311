"""The dyno's moving mass estimated from a damper record (issue 29, item 4): the dyno simulator's lab record with its
2 kg fixture and without it; `nnfmu train` reports the estimate and warns at defaults, `--moving-mass auto` removes
it."""

from __future__ import annotations

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
    assert estimate.matters and estimate.share > 0.03  # m·a is a few per cent of this record's force rms
    assert "± 0.0" in estimate.describe() and "kg (95 %)" in estimate.describe()


@pytest.mark.slow
def test_no_fixture_gives_zero_within_its_confidence() -> None:
    estimate = estimate_moving_mass(_dyno(WITHOUT_FIXTURE))
    assert abs(estimate.mass) <= estimate.half_width < 0.05, estimate
    assert not estimate.matters


@pytest.mark.slow
def test_train_reports_and_warns_at_defaults_and_auto_removes_the_mass(
    with_fixture: Measurement, tmp_path: Path
) -> None:
    data = save_measurement(with_fixture, tmp_path / "dyno.csv")
    tiny = ["--preset", "damper-spline", "--max-epochs", "2", "--restarts", "1", "--hidden", "2"]
    plain = runner.invoke(app, ["train", str(data), "--out", str(tmp_path / "plain.onnx"), *tiny])
    assert plain.exit_code == 0, plain.output
    text = " ".join(plain.output.split())  # rich wraps long lines
    assert "note: moving mass between load cell and actuator estimated from the record: 1.9" in text
    assert "warning: force holds m·a of an estimated 1.9" in text and "--moving-mass auto" in text
    assert "compensated for" not in text
    auto = runner.invoke(
        app, ["train", str(data), "--out", str(tmp_path / "auto.onnx"), "--moving-mass", "auto", *tiny]
    )
    assert auto.exit_code == 0, auto.output
    text = " ".join(auto.output.split())
    assert "note: force compensated for 1.9" in text and "kg of moving mass" in text
    assert "warning: force holds" not in text
    bad = runner.invoke(app, ["train", str(data), "--out", str(tmp_path / "x.onnx"), "--moving-mass", "heavy", *tiny])
    assert bad.exit_code == 2
    assert "give a mass in kg (e.g. 2.0) or auto, not 'heavy'" in " ".join(bad.output.replace("│", " ").split())
