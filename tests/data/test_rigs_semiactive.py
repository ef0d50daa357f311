"""Semi-active damper dynos (`rig damper --type mr|cdc`): the command channel beside stroke and load, read back with
its unit, the truth beside the data, and the passive dyno untouched by the new option."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.data import load_measurement
from nnfmu.data.rigs import RigOptions, simulate_rig, write_rig
from nnfmu.errors import SettingsError
from nnfmu.physics import CDC_CURRENT_RANGE, MR_VOLTAGE_RANGE

SHORT = dict(duration=4.0, excitation="random", seed=5)


@pytest.mark.parametrize(
    ("damper_type", "channel", "unit", "span"),
    [
        ("mr", "voltage", "V", MR_VOLTAGE_RANGE),
        ("cdc", "current", "A", CDC_CURRENT_RANGE),
    ],
)
def test_record_loads_back_with_the_command_and_its_unit(tmp_path, damper_type, channel, unit, span):
    options = RigOptions(damper_type=damper_type, **SHORT)
    data, truth_file = write_rig("damper", tmp_path / f"{damper_type}.csv", options)
    measurement = load_measurement(data, required=["displacement", "velocity", "force", channel])
    assert measurement.units == {
        "displacement": "m",
        "velocity": "m/s",
        "force": "N",
        channel: unit,
        "acceleration": "m/s^2",
    }  # the loader derives the acceleration
    command = measurement[channel]
    noise = 5 * 0.0005 * (10.0 if unit == "V" else 2.0)
    assert span[0] - noise <= command.min() and command.max() <= span[1] + noise
    assert np.ptp(command) > 0.5 * (span[1] - span[0])  # the schedule visits the range
    truth = json.loads(truth_file.read_text())
    assert truth["kind"] == "damper" and truth["damper_type"] == damper_type
    assert truth["excitation"]["command"]["channel"] == channel and truth["excitation"]["command"]["unit"] == unit
    assert sum(truth["excitation"]["command"]["segments"].values()) >= 4
    assert all("unit" in row for row in truth["parameters"].values() if "value" in row)
    assert truth["channels"][channel] == unit


def test_the_force_follows_the_command():
    """Within one record, the force in a band of rebound speeds is higher where the command is high."""
    for damper_type, channel in (("mr", "voltage"), ("cdc", "current")):
        m = simulate_rig(
            "damper", RigOptions(damper_type=damper_type, noise=0.0, duration=6.0, excitation="random", effects=())
        ).measurement
        v, f, c = m["velocity"], m["force"], m[channel]
        band = (v > 0.3) & (v < 0.6)
        low, high = np.quantile(c[band], [0.25, 0.75])
        assert f[band & (c > high)].mean() > 1.5 * f[band & (c < low)].mean() > 0


def test_the_stroke_is_the_passive_dynos_and_the_command_its_own_stream():
    passive = simulate_rig("damper", RigOptions(noise=0.0, **SHORT)).measurement
    mr = simulate_rig("damper", RigOptions(noise=0.0, damper_type="mr", **SHORT)).measurement
    cdc = simulate_rig("damper", RigOptions(noise=0.0, damper_type="cdc", **SHORT)).measurement
    np.testing.assert_array_equal(mr["displacement"], passive["displacement"])
    np.testing.assert_array_equal(cdc["velocity"], passive["velocity"])
    again = simulate_rig("damper", RigOptions(damper_type="mr", **SHORT)).measurement
    np.testing.assert_array_equal(
        again["voltage"], simulate_rig("damper", RigOptions(damper_type="mr", **SHORT)).measurement["voltage"]
    )
    other = simulate_rig("damper", RigOptions(damper_type="mr", **dict(SHORT, seed=6))).measurement
    assert not np.array_equal(other["voltage"], again["voltage"])


def test_passive_is_the_default_and_its_truth_names_no_type(tmp_path):
    default = write_rig("damper", tmp_path / "a.csv", RigOptions(**SHORT))
    named = write_rig("damper", tmp_path / "b.csv", RigOptions(damper_type="passive", **SHORT))
    assert default[0].read_bytes() == named[0].read_bytes()
    assert default[1].read_text() == named[1].read_text()
    truth = json.loads(default[1].read_text())
    assert "damper_type" not in truth and "damper_type" not in truth["options"]


def test_effects_are_switched_per_type():
    off = simulate_rig("damper", RigOptions(noise=0.0, damper_type="mr", effects=(), **SHORT))
    gas = simulate_rig("damper", RigOptions(noise=0.0, damper_type="mr", effects=("gas_force",), **SHORT))
    params = gas.truth["parameters"]
    shift = params["k1"]["value"] * (gas.measurement["displacement"] - params["x0"]["value"])
    np.testing.assert_allclose(gas.measurement["force"] - off.measurement["force"], shift, atol=1e-9)
    assert off.truth["effects"] == [] and gas.truth["effects"] == ["gas_force"]


@pytest.mark.parametrize(
    ("kind", "options", "message"),
    [
        ("bushing", RigOptions(damper_type="mr"), "for the damper dyno"),
        ("damper", RigOptions(damper_type="skyhook"), "unknown damper type 'skyhook'"),
        ("damper", RigOptions(damper_type="mr", effects=("temperature",)), "valid mr damper effects"),
        ("damper", RigOptions(damper_type="cdc", excitation="vehicle"), "no vehicle-derived drive"),
    ],
)
def test_bad_combinations_are_refused(kind, options, message):
    with pytest.raises(SettingsError, match=message):
        simulate_rig(kind, options)


def test_cli_type_option(tmp_path: Path):
    runner = CliRunner()
    out = tmp_path / "cdc.csv"
    result = runner.invoke(
        app, ["rig", "damper", "--type", "cdc", "--out", str(out), "--duration", "3", "--excitation", "random"]
    )
    assert result.exit_code == 0, result.output
    assert "current [A]" in out.read_text().splitlines()[0]
    refused = runner.invoke(app, ["rig", "damper", "--type", "semi", "--out", str(tmp_path / "x.csv")])
    assert refused.exit_code != 0 and "unknown damper type 'semi'" in refused.output
