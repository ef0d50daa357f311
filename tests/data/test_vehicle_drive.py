"""Vehicle-derived bushing rig drives: spectrum follows the source, peaks exceed it by the margin, errors, CLI,
truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import welch
from typer.testing import CliRunner

from nnfmu.cli import app
from nnfmu.data import DataError, Measurement, load_measurement, save_measurement
from nnfmu.data.rigs import (
    BUSHING_CHANNELS,
    BushingRig,
    DriveDesign,
    RigOptions,
    SpectrumShape,
    design_vehicle_drive,
    simulate_vehicle_rig,
)
from nnfmu.data.rigs.excitation import random_motion
from nnfmu.data.rigs.sensors import Sensor

RATE = 500.0
ELEMENT = "bushing_fl_front"
# Source deflections unlike the default lab drive: each channel its own band and working point (SI units).
SOURCE = {
    "axial": (SpectrumShape(5.0, 20.0, 30.0, 2.0), 1e-4, 3e-5),
    "radial": (SpectrumShape(1.0, 2.0, 100.0, 1.0), -5e-6, 3e-6),  # content up to 100 Hz, beyond the rig's band
    "axial_rotation": (SpectrumShape(0.5, 1.5, 12.0, 3.0), 0.025, 0.02),
    "conical_rotation": (SpectrumShape(2.0, 8.0, 40.0, 2.0), 0.0014, 0.001),
}


def source_result(seconds: float = 20.0, elements: tuple[str, ...] = (ELEMENT,), seed: int = 0) -> Measurement:
    """A vehicle result with the four deflections of each element: offset + rms x a random motion of its shape."""
    n = int(seconds * RATE)
    channels, units = {}, {}
    rng = np.random.default_rng(seed)
    for element in elements:
        for key, (shape, mean, rms) in SOURCE.items():
            name = f"{element}_{BUSHING_CHANNELS[key].position}"
            channels[name] = mean + rms * random_motion(shape, RATE, n, rng, fade=0.5).x
            units[name] = BUSHING_CHANNELS[key].position_unit
    return Measurement(np.arange(n) / RATE, channels, units, source="vehicle-result.csv")


def band_shares(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Share of the variance of x inside [0.5, 40] Hz that falls in each band between `edges` [Hz]."""
    f, p = welch(x - x.mean(), fs=RATE, nperseg=int(4 * RATE))
    powers = np.array([p[(f >= lo) & (f < hi)].sum() for lo, hi in zip(edges[:-1], edges[1:])])
    return powers / p[(f >= 0.5) & (f <= 40.0)].sum()


@pytest.fixture(scope="module")
def source() -> Measurement:
    return source_result()


@pytest.fixture(scope="module")
def drive(source: Measurement):
    return design_vehicle_drive(source, [ELEMENT], RATE, int(60 * RATE), seed=3, design=DriveDesign(margin=1.3))


def test_drive_spectrum_follows_the_source_inside_the_rig_band(source: Measurement, drive) -> None:
    edges = 2.0 ** np.arange(0, 5.5, 0.5) * 1.0  # half-octave bands 1-32 Hz
    for key in SOURCE:
        simulated = source[f"{ELEMENT}_{BUSHING_CHANNELS[key].position}"]
        expected, designed = band_shares(simulated, edges), band_shares(drive.motions[key].x, edges)
        carrying = expected > 0.02  # bands holding a real share of the source's variance
        assert carrying.sum() >= 3, key
        ratio = designed[carrying] / expected[carrying]
        assert np.all((ratio > 0.7) & (ratio < 1.4)), (key, ratio)
        assert np.all(designed[expected < 1e-4] < 0.01), key  # no content where the source has none


def test_drive_leaves_out_what_the_rig_controller_cannot_reproduce(source: Measurement, drive) -> None:
    f, p = welch(drive.motions["radial"].x, fs=RATE, nperseg=int(4 * RATE))
    assert p[f > 45.0].sum() < 1e-6 * p.sum()  # the source has ~20 % of its variance at 40-100 Hz
    assert 0.05 < drive.channels["radial"].share_outside_band < 0.5


def test_drive_peaks_and_rates_exceed_the_source_by_the_margin(source: Measurement, drive) -> None:
    for key, design in drive.channels.items():
        x, v = drive.motions[key].x, drive.motions[key].v
        simulated = design.simulated[ELEMENT]
        above = (x.max() - simulated.mean) / (simulated.max - simulated.mean)
        below = (simulated.mean - x.min()) / (simulated.mean - simulated.min)
        deflection = source[f"{ELEMENT}_{BUSHING_CHANNELS[key].position}"]
        rate = np.max(np.abs(v)) / np.max(np.abs(np.gradient(deflection, source.sample_period)))
        assert min(min(above, below), rate) == pytest.approx(1.3, rel=1e-9), key  # what needs most sets the scale
        assert min(above, below, rate) >= 1.3 - 1e-9, key
        assert design.working_point == pytest.approx(simulated.mean)


def test_drive_starts_where_the_vehicle_starts_the_bushing_or_at_rest(source: Measurement, drive) -> None:
    at_rest = design_vehicle_drive(source, [ELEMENT], RATE, int(10 * RATE), seed=3, design=DriveDesign(settled=False))
    for key in SOURCE:
        x, initial = drive.motions[key].x, source[f"{ELEMENT}_{BUSHING_CHANNELS[key].position}"][0]
        assert drive.channels[key].start == initial
        # settled at the car's static deflection, where the reference relaxes the bushing's friction
        assert abs(x[0] - initial) < 1e-3 * np.ptp(x) and abs(x[-1] - initial) < 1e-3 * np.ptp(x)
        y = at_rest.motions[key].x
        assert abs(y[0]) < 1e-3 * np.ptp(y) and abs(y[-1]) < 1e-3 * np.ptp(y)
        middle = slice(len(x) // 3, 2 * len(x) // 3)
        assert np.mean(x[middle]) == pytest.approx(drive.channels[key].working_point, abs=0.2 * np.std(x))


def test_drive_rates_are_the_positions_derivatives(drive) -> None:
    for motion in drive.motions.values():
        numeric = np.gradient(motion.x, 1 / RATE)  # a central difference is 2.4 % low at 30 Hz sampled at 500 Hz
        assert np.max(np.abs(numeric[5:-5] - motion.v[5:-5])) < 0.05 * np.max(np.abs(motion.v))


def test_several_elements_make_one_envelope_covering_all() -> None:
    two = source_result(elements=(ELEMENT, "bushing_fl_rear"), seed=4)
    rear = two[f"bushing_fl_rear_{BUSHING_CHANNELS['radial'].position}"]
    two.channels[f"bushing_fl_rear_{BUSHING_CHANNELS['radial'].position}"] = 3 * rear  # the rear moves more
    drive = design_vehicle_drive(two, [ELEMENT, "bushing_fl_rear"], RATE, int(30 * RATE), seed=1)
    x = drive.motions["radial"].x
    for element in (ELEMENT, "bushing_fl_rear"):
        simulated = two[f"{element}_{BUSHING_CHANNELS['radial'].position}"]
        assert x.max() >= simulated.max() and x.min() <= simulated.min()


def test_missing_channel_is_named_with_the_file(source: Measurement) -> None:
    with pytest.raises(DataError, match=r"vehicle-result\.csv.*bushing_fr_front_axial_displacement"):
        design_vehicle_drive(source, ["bushing_fr_front"], RATE, 1000, seed=0)


def test_wrong_unit_is_named(source: Measurement) -> None:
    name = f"{ELEMENT}_conical_rotation"
    bad = Measurement(source.time, dict(source.channels), dict(source.units) | {name: "m"}, source.source)
    with pytest.raises(DataError, match=rf"{name}.*'m'.*'rad'"):
        design_vehicle_drive(bad, [ELEMENT], RATE, 1000, seed=0)


def test_still_channel_is_refused(source: Measurement) -> None:
    name = f"{ELEMENT}_axial_displacement"
    still = Measurement(
        source.time, dict(source.channels) | {name: np.full(len(source), 1e-4)}, source.units, source.source
    )
    with pytest.raises(DataError, match=r"axial deflection .* does not move"):
        design_vehicle_drive(still, [ELEMENT], RATE, 1000, seed=0)


def test_design_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="margin"):
        DriveDesign(margin=0.9)
    with pytest.raises(ValueError, match="band"):
        DriveDesign(band=(40.0, 0.5))


def test_sensor_range_is_the_smallest_standard_one_covering_the_test() -> None:
    load_cell = Sensor(25e3, 0.001)
    assert load_cell.sized_for(150.0, 1.25).full_scale == 200.0
    assert load_cell.sized_for(170.0, 1.25).full_scale == 500.0
    assert load_cell.sized_for(4e4, 1.25).full_scale == 25e3  # never a larger transducer than the rig has
    assert load_cell.sized_for(150.0, 1.25).noise_rms == pytest.approx(0.2)


def test_rig_run_records_with_transducers_sized_for_the_drive(source: Measurement) -> None:
    options = RigOptions(duration=8.0, sample_rate=RATE, seed=2)
    sized = simulate_vehicle_rig(source, [ELEMENT], options)
    default = simulate_vehicle_rig(source, [ELEMENT], options, DriveDesign(fit_sensors=False))
    rig = BushingRig()
    for name, recorded in sized.truth["sensors"].items():
        peak = float(np.max(np.abs(default.measurement[name])))
        assert recorded["test_peak"] <= recorded["full_scale"] <= rig.sensors[name].full_scale
        assert default.truth["sensors"][name]["full_scale"] == rig.sensors[name].full_scale
        assert peak > 0
    name = "radial_force"
    clean = simulate_vehicle_rig(source, [ELEMENT], RigOptions(duration=8.0, sample_rate=RATE, seed=2, noise=0.0))
    noise_sized = np.std(sized.measurement[name] - clean.measurement[name])
    noise_default = np.std(default.measurement[name] - clean.measurement[name])
    assert noise_sized < noise_default / 20  # a 25 kN load cell under a ~100 N test is mostly noise


def test_cli_writes_the_record_and_the_design_into_the_truth(tmp_path: Path, source: Measurement) -> None:
    result_file = save_measurement(source, tmp_path / "reference.csv")
    out = tmp_path / "rig.csv"
    done = CliRunner().invoke(
        app,
        [
            "rig",
            "bushing",
            "--drive-from",
            str(result_file),
            "--element",
            ELEMENT,
            "--margin",
            "1.3",
            "--duration",
            "6",
            "--sample-rate",
            "500",
            "--out",
            str(out),
        ],
    )
    assert done.exit_code == 0, done.output
    record = load_measurement(out)
    assert {c for ch in BUSHING_CHANNELS.values() for c in (ch.position, ch.rate, ch.force)} <= set(record.names)
    truth = json.loads(out.with_name("rig.truth.json").read_text())
    drives = truth["excitation"]["drives"]
    assert drives["source"] == str(result_file) and drives["elements"] == [ELEMENT]
    assert drives["design"]["margin"] == 1.3 and truth["options"]["excitation"] == "vehicle"
    for key in SOURCE:
        channel = drives["channels"][key]
        simulated = channel["simulated"][ELEMENT]
        assert simulated["rms"] == pytest.approx(
            np.std(source[f"{ELEMENT}_{BUSHING_CHANNELS[key].position}"]), rel=1e-3
        )  # the CSV keeps ~7 significant digits
        assert channel["designed"]["max"] > simulated["max"] and channel["designed"]["min"] < simulated["min"]
        assert channel["designed"]["rms"] > 0


@pytest.mark.parametrize(
    "args, message",
    [
        (["rig", "bushing", "--drive-from", "{src}", "--out", "{out}"], "--element"),
        (
            ["rig", "damper", "--drive-from", "{src}", "--element", ELEMENT, "--out", "{out}"],
            "no channel 'bushing_fl_front_displacement' for the stroke of bushing_fl_front",
        ),
        (
            ["rig", "damper", "--drive-from", "{src}", "--element", ELEMENT, "--default-sensors", "--out", "{out}"],
            "--default-sensors is for the bushing rig",
        ),
        (
            ["rig", "bushing", "--drive-from", "{src}", "--element", ELEMENT, "--excitation", "lab", "--out", "{out}"],
            "cannot be 'lab'",
        ),
        (["rig", "bushing", "--excitation", "vehicle", "--out", "{out}"], "needs --drive-from"),
        (
            ["rig", "bushing", "--drive-from", "{src}", "--element", "bushing_rl_front", "--out", "{out}"],
            "bushing_rl_front_axial_displacement",
        ),
        (["rig", "bushing", "--drive-from", "{missing}", "--element", ELEMENT, "--out", "{out}"], "no such file"),
        (
            ["rig", "bushing", "--drive-from", "{src}", "--element", ELEMENT, "--band", "40", "--out", "{out}"],
            "LOW:HIGH",
        ),
    ],
)
def test_cli_refuses_bad_drive_options(tmp_path: Path, source: Measurement, args: list[str], message: str) -> None:
    src = save_measurement(source.slice(0, 2000), tmp_path / "reference.csv")
    out = tmp_path / "rig.csv"
    filled = [a.format(src=src, out=out, missing=tmp_path / "nothing.csv") for a in args]
    done = CliRunner().invoke(app, filled)
    assert done.exit_code == 2, done.output
    assert message in done.output
    assert not out.exists()
