"""Vehicle-derived damper dyno drives: the lab sine series, then a stroke whose spectrum follows the car's damper
strokes up to the dyno's band, whose excursions and peak rate exceed the simulated ones by the margin; CLI and
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
    RIG_BANDS,
    DamperDyno,
    DriveDesign,
    RigOptions,
    SpectrumShape,
    design_damper_drive,
    simulate_rig,
    simulate_vehicle_damper_dyno,
)
from nnfmu.data.rigs.excitation import random_motion
from nnfmu.data.rigs.vehicle_dyno import sine_peak_velocities

RATE = 1000.0
ELEMENTS = ("damper_fl", "damper_rl")
# Strokes unlike the lab's random part (flat velocity 1-20 Hz): body motion plus wheel hop and short road waves up
# to 80 Hz, about a compressed working point (SI units).
SHAPES = {
    "damper_fl": (SpectrumShape(0.8, 1.5, 80.0, 1.5), -0.006, 0.008),
    "damper_rl": (SpectrumShape(0.8, 1.5, 80.0, 1.5), -0.004, 0.006),
}


def source_result(seconds: float = 30.0, seed: int = 0) -> Measurement:
    n = int(seconds * RATE)
    rng = np.random.default_rng(seed)
    channels = {
        f"{e}_displacement": mean + rms * random_motion(shape, RATE, n, rng, fade=0.5).x
        for e, (shape, mean, rms) in SHAPES.items()
    }
    return Measurement(np.arange(n) / RATE, channels, {name: "m" for name in channels}, source="vehicle-result.csv")


@pytest.fixture(scope="module")
def source() -> Measurement:
    return source_result()


def test_the_stroke_follows_the_cars_spectrum_and_exceeds_its_excursions_and_rates(source: Measurement) -> None:
    design = DriveDesign(margin=1.3, band=RIG_BANDS["damper"])
    drive = design_damper_drive(source, ELEMENTS, RATE, int(60 * RATE), seed=1, design=design)
    motion = drive.motions["displacement"]
    assert motion.x[0] == 0.0  # at rest, where the dyno's sine series ends
    strokes = [np.asarray(source[f"{e}_displacement"]) for e in ELEMENTS]
    # each side reaches margin x the simulated excursion about each stroke's own mean
    assert np.max(motion.x) >= max(x.mean() + 1.3 * (x.max() - x.mean()) for x in strokes) - 1e-12
    assert np.min(motion.x) <= min(x.mean() + 1.3 * (x.min() - x.mean()) for x in strokes) + 1e-12
    rate_peak = max(np.max(np.abs(np.gradient(x, 1 / RATE))) for x in strokes)
    assert np.max(np.abs(motion.v)) >= 1.3 * rate_peak * (1 - 1e-9)
    # the car's share of stroke variance per band, 1-10 / 10-40 / 40-100 Hz, is the drive's within a few points
    edges = np.array([1.0, 10.0, 40.0, 100.0])

    def shares(x: np.ndarray) -> np.ndarray:
        f, p = welch(x - x.mean(), fs=RATE, nperseg=int(4 * RATE))
        powers = np.array([p[(f >= lo) & (f < hi)].sum() for lo, hi in zip(edges[:-1], edges[1:])])
        return powers / powers.sum()

    steady = motion.x[int(2 * RATE) : -int(2 * RATE)]
    np.testing.assert_allclose(shares(steady), np.mean([shares(x) for x in strokes], axis=0), atol=0.03)
    assert shares(steady)[2] > 1e-3  # content above 40 Hz, where the lab drive has none


def test_the_record_keeps_the_lab_sine_series_and_replaces_only_the_random_part(source: Measurement) -> None:
    options = RigOptions(duration=45.0, seed=4)
    lab = simulate_rig("damper", options)
    vehicle = simulate_vehicle_damper_dyno(source, ELEMENTS, options, DriveDesign(band=RIG_BANDS["damper"]))
    parts = vehicle.truth["excitation"]["parts"]
    assert [p["type"] for p in parts] == ["sine series", "vehicle-derived stroke"]
    sine_end = int(parts[0]["end_s"] * 1000.0)
    recorded, lab_recorded = vehicle.measurement, lab.measurement
    np.testing.assert_array_equal(recorded["force"][: sine_end // 2], lab_recorded["force"][: sine_end // 2])
    assert vehicle.truth["options"]["excitation"] == "vehicle"
    assert vehicle.truth["excitation"]["drive"]["elements"] == list(ELEMENTS)
    assert not np.array_equal(recorded["displacement"][sine_end:], lab_recorded["displacement"][sine_end:])


def test_the_sine_series_stops_at_the_first_level_covering_the_cars_fastest_stroke() -> None:
    lab = DamperDyno().peak_velocities
    t = np.arange(int(20 * RATE)) / RATE
    # slow strokes: 10 mm at 5 Hz (0.314 m/s peak rate) and 5 mm at 4 Hz; margin 1.2 -> 0.377 m/s -> levels to 0.4
    slow = Measurement(
        t,
        {
            "damper_fl_displacement": 0.01 * np.sin(2 * np.pi * 5.0 * t),
            "damper_rl_displacement": 0.005 * np.sin(2 * np.pi * 4.0 * t),
        },
        {"damper_fl_displacement": "m", "damper_rl_displacement": "m"},
        source="slow.csv",
    )
    assert sine_peak_velocities(slow, ELEMENTS, 1.2, lab) == (0.05, 0.1, 0.2, 0.3, 0.4)
    assert sine_peak_velocities(slow, ELEMENTS, 1.0, lab) == (0.05, 0.1, 0.2, 0.3, 0.4)  # 0.314 m/s
    assert sine_peak_velocities(slow, ELEMENTS, 2.0, lab) == (0.05, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8)  # 0.628 m/s
    assert sine_peak_velocities(slow, ELEMENTS, 20.0, lab) == lab  # past the fastest level: all of them
    run = simulate_vehicle_damper_dyno(slow, ELEMENTS, RigOptions(duration=45.0, seed=2), DriveDesign(margin=1.2))
    sine = run.truth["excitation"]["parts"][0]
    assert [round(level["peak_rate"], 9) for level in sine["levels"]] == [0.05, 0.1, 0.2, 0.3, 0.4]
    recorded = run.measurement["velocity"][: int(sine["end_s"] * 1000.0)]
    assert 0.39 < np.max(np.abs(recorded)) < 0.42  # the top level, the transducer's 2 mm/s noise on it


def test_bad_sources_and_bands_are_refused_naming_them(source: Measurement) -> None:
    design = DriveDesign(band=RIG_BANDS["damper"])
    with pytest.raises(DataError, match="no channel 'damper_fr_displacement' for the stroke of damper_fr"):
        design_damper_drive(source, ["damper_fr"], RATE, 1000, 0, design)
    wrong = Measurement(
        source.time,
        {"damper_fl_displacement": source["damper_fl_displacement"]},
        {"damper_fl_displacement": "m/s"},
        source="speeds.csv",
    )
    with pytest.raises(DataError, match="'damper_fl_displacement' is in 'm/s'"):
        design_damper_drive(wrong, ["damper_fl"], RATE, 1000, 0, design)
    with pytest.raises(ValueError, match="Nyquist"):
        design_damper_drive(source, ELEMENTS, 150.0, 1000, 0, design)
    with pytest.raises(ValueError, match="needs a stroke derived from a vehicle result"):
        DamperDyno().motion("vehicle", RATE, 45_000, np.random.default_rng(0))


def test_cli_writes_the_record_with_the_dynos_band_by_default(tmp_path: Path, source: Measurement) -> None:
    result_file = save_measurement(source, tmp_path / "reference.csv")
    out = tmp_path / "dyno.csv"
    done = CliRunner().invoke(
        app,
        [
            "rig",
            "damper",
            "--drive-from",
            str(result_file),
            "--element",
            ",".join(ELEMENTS),
            "--duration",
            "45",
            "--out",
            str(out),
        ],
    )
    assert done.exit_code == 0, done.output
    record = load_measurement(out)
    assert {"displacement", "velocity", "force"} <= set(record.names)
    truth = json.loads(out.with_name("dyno.truth.json").read_text())
    drive = truth["excitation"]["drive"]
    assert drive["source"] == str(result_file) and drive["design"]["band"] == list(RIG_BANDS["damper"])
