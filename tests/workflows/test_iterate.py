"""`nnfmu iterate` on virtual cars: road records made by driving the car with a known drive (never shown to the
iteration), recovered by iterating through the co-simulation master; quarter cars with a linear damper, the parameter
file's digressive, asymmetric spline damper and a trained damper-hysteresis network FMU, and the full vehicle on four
posts (twelve targets); bad input refused by name."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.data import Measurement, save_measurement
from nnfmu.data.drive_files import read_drive
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics.parameters import DEFAULTS_DIR
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu
from nnfmu.workflows.cosim import run_cosim
from nnfmu.workflows.iterate import IterateError, IterateSettings, run_iterate
from nnfmu.workflows.iterate.signals import band_filter, fade_weights
from nnfmu.workflows.roadtest.systems import bushing_elements, damper_elements

H = 1e-3  # [s] sample period of the records, the vehicle and the co-simulation step
DURATION = 8.0  # [s] of road record
TARGETS = ("spindle_acceleration", "body_acceleration", "damper_displacement")
SETTINGS = IterateSettings(noise_duration=20.0, resolution=0.25, band=(0.3, 100.0), rpc=True)
PARAMS = DEFAULTS_DIR / "midsize_sedan_quarter_car_fl.toml"


def _car(folder: Path, damper_model: str) -> Path:
    """SystemStructure.ssd of the quarter car with its damper built in as `damper_model` ("linear" or "spline")."""
    folder.mkdir(parents=True)
    params = folder / "quarter_car.toml"
    text = PARAMS.read_text(encoding="utf-8").replace('model = "spline"', f'model = "{damper_model}"')
    if damper_model == "linear":  # the force-velocity table belongs to the spline only
        text = "\n".join(line for line in text.splitlines() if not line.startswith(("velocity =", "force =")))
    params.write_text(text, encoding="utf-8")
    settings = VehicleBuildSettings(
        params_path=params, components={"damper": "reference"}, sample_period=H, platforms=("linux64",)
    )
    fmu = build_vehicle_fmu("quarter-car", folder / "quarter_car.fmu", settings)
    return write_ssd(connect_by_name("quarter car", ("vehicle", fmu), {}, folder), folder / "SystemStructure.ssd")


@pytest.fixture(scope="module")
def cars(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("iterate")
    return {model: _car(base / model, model) for model in ("linear", "spline")}


def _road_drive() -> Measurement:
    """The known drive: a class C road at 20 m/s under the fl post, from rest and back to rest (velocity its
    gradient, as the iteration writes it)."""
    road = generate_drive(DriveSettings(duration=DURATION, seed=7))
    x = road["actuator_fl_displacement"] * fade_weights(len(road.time), H, 0.5)
    return Measurement(
        time=road.time,
        channels={"actuator_fl_displacement": x, "actuator_fl_velocity": np.gradient(x, H)},
        units={"actuator_fl_displacement": "m", "actuator_fl_velocity": "m/s"},
        source="known road drive",
    )


def _road_record(ssd: Path, drive: Measurement, path: Path, noise: float = 0.02) -> Measurement:
    """The car's noiseless response to `drive`; the target file gets it with white sensor noise of `noise` x each
    channel's standard deviation."""
    with open_system(ssd) as system:
        response = cosimulate(system, drive, CosimSettings(step=H, stop_time=float(drive.time[-1]))).measurement
    rng = np.random.default_rng(1)
    noisy = {c: response[c] + noise * np.std(response[c]) * rng.normal(size=len(response.time)) for c in TARGETS}
    save_measurement(
        Measurement(time=response.time, channels=noisy, units={c: response.units[c] for c in TARGETS}, source="road"),
        path,
    )
    return response


def _nrmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


@pytest.mark.slow
@pytest.mark.parametrize("model", ["linear", "spline"])
def test_iteration_recovers_the_road_responses_and_the_drive_in_band(
    cars: dict[str, Path], model: str, tmp_path: Path
) -> None:
    known = _road_drive()
    road = _road_record(cars[model], known, tmp_path / "road.csv")
    result = run_iterate(tmp_path / "road.csv", cars[model], tmp_path / "out", SETTINGS)
    assert result.converged
    assert len(result.outcome.iterations) <= SETTINGS.iterations
    drive = read_drive(result.files["drive"])  # exactly what `nnfmu cosim --drive` reads
    assert set(drive.names) == {"actuator_fl_displacement", "actuator_fl_velocity"}
    rpc = read_drive(result.files["drive_rpc"])  # the same drive as RPC III (int16: within half a count)
    for channel in drive.names:
        count = np.max(np.abs(drive[channel])) / 32752
        np.testing.assert_allclose(rpc[channel], drive[channel], rtol=0, atol=0.6 * count)
    replay = run_cosim(cars[model], result.files["drive"], CosimSettings(step=H)).measurement
    n = min(len(replay.time), len(road.time))
    for channel in TARGETS:
        assert _nrmse(replay[channel][:n], road[channel][:n]) < 0.05, channel
    # within the band where the responses see the post (2-30 Hz), the drive is the road's
    x, true = drive["actuator_fl_displacement"], known["actuator_fl_displacement"]
    n = min(len(x), len(true))
    band = (2.0, 30.0)
    assert _nrmse(band_filter(x[:n], H, band), band_filter(true[:n], H, band)) < 0.05
    # at rest at both ends, and within the actuator limits
    v = drive["actuator_fl_velocity"]
    assert x[0] == 0.0 and x[-1] == 0.0 and abs(v[0]) < 1e-3 and abs(v[-1]) < 1e-3
    report = json.loads(result.files["report"].read_text(encoding="utf-8"))
    assert report["converged"] and report["channels"] == list(TARGETS)
    last = report["iterations"][-1]
    assert all(value <= 1.0 for value in last["limit_use"].values())
    assert set(last["channels"]["body_acceleration"]) >= {
        "nrmse",
        "rms_ratio_db",
        "global_rms_error",
        "pseudo_damage_ratio",
    }
    assert report["coherence"]["mean_in_band"]["spindle_acceleration"] > 0.9
    assert "<img" in result.files["html"].read_text(encoding="utf-8")


@pytest.mark.slow
def test_tight_actuator_limits_are_never_exceeded(cars: dict[str, Path], tmp_path: Path) -> None:
    _road_record(cars["linear"], _road_drive(), tmp_path / "road.csv")
    from nnfmu.workflows.iterate import ActuatorLimits

    limits = ActuatorLimits(stroke=0.02, velocity=0.3, acceleration=40.0)  # below what the road needs
    settings = IterateSettings(noise_duration=20.0, resolution=0.25, band=(0.3, 100.0), iterations=3, limits=limits)
    result = run_iterate(tmp_path / "road.csv", cars["linear"], tmp_path / "out", settings)
    assert not result.converged
    x = read_drive(result.files["drive"])["actuator_fl_displacement"]
    v = np.gradient(x, H)
    assert np.max(np.abs(x)) <= 0.02 and np.max(np.abs(v)) <= 0.3 + 1e-9
    assert np.max(np.abs(np.gradient(v, H))) <= 40.0 + 1e-9
    assert any(it.step_taken < 1.0 for it in result.outcome.iterations)


def test_bad_input_is_refused_naming_the_file_channel_or_value(cars: dict[str, Path], tmp_path: Path) -> None:
    t = np.arange(4001) * H
    target = tmp_path / "road.csv"
    save_measurement(
        Measurement(
            time=t,
            channels={"body_acceleration": np.sin(2 * np.pi * 1.5 * t), "wheel_temperature": np.full_like(t, 293.0)},
            units={"body_acceleration": "m/s^2", "wheel_temperature": "K"},
            source="road",
        ),
        target,
    )
    ssd = cars["linear"]
    with pytest.raises(IterateError, match=r"road.csv: no channel 'spindle_acceleration' in the target"):
        run_iterate(target, ssd, tmp_path / "a", IterateSettings(channels=("spindle_acceleration",)))
    with pytest.raises(IterateError, match=r"channel 'wheel_temperature' of the target is not an output"):
        run_iterate(target, ssd, tmp_path / "b", IterateSettings(channels=("body_acceleration", "wheel_temperature")))
    with pytest.raises(IterateError, match=r"band 1:600 Hz: the high edge lies above 500 Hz.*road.csv"):
        run_iterate(target, ssd, tmp_path / "c", IterateSettings(band=(1.0, 600.0)))
    assert not any((tmp_path / name).exists() for name in "abc")


WALK_NETWORK = Path(__file__).parents[1] / "models" / "data" / "damper-hysteresis-walk.onnx"  # a trained network


@pytest.mark.slow
def test_a_car_with_a_damper_network_is_iterated_to_its_road_responses(tmp_path: Path) -> None:
    """The nonlinear car of the issue: the quarter car's damper port closed by a trained damper-hysteresis network
    FMU (the README walk's network), its road record made with a drive the iteration never sees."""
    damper = build_fmu(WALK_NETWORK, BuildOptions(out=tmp_path / "parts" / "damper.fmu", platforms=("linux64",)))
    settings = VehicleBuildSettings(params_path=PARAMS, sample_period=H, platforms=("linux64",))
    vehicle = build_vehicle_fmu("quarter-car", tmp_path / "parts" / "quarter_car.fmu", settings)
    system = connect_by_name(
        "quarter car, damper network", ("vehicle", vehicle), {"damper": damper}, tmp_path / "parts"
    )
    ssd = write_ssd(system, tmp_path / "parts" / "SystemStructure.ssd")
    road = _road_record(ssd, _road_drive(), tmp_path / "road.csv")
    result = run_iterate(tmp_path / "road.csv", ssd, tmp_path / "out", SETTINGS)
    assert result.converged and len(result.outcome.iterations) <= SETTINGS.iterations
    replay = run_cosim(ssd, result.files["drive"], CosimSettings(step=H)).measurement
    n = min(len(replay.time), len(road.time))
    for channel in TARGETS:
        assert _nrmse(replay[channel][:n], road[channel][:n]) < 0.05, channel


@pytest.mark.slow
def test_the_full_vehicle_is_iterated_with_four_actuators_to_twelve_targets(tmp_path: Path) -> None:
    """MIMO: the full vehicle on its four posts (components built in), twelve targets (each corner's spindle and body
    acceleration and damper stroke) from a four-post road drive the iteration never sees."""
    corners = ("fl", "fr", "rl", "rr")
    targets = tuple(
        name
        for c in corners
        for name in (f"spindle_{c}_acceleration", f"body_acceleration_{c}", f"damper_{c}_displacement")
    )
    built_in = {name: "reference" for name in damper_elements("full-vehicle") + bushing_elements("full-vehicle")}
    settings = VehicleBuildSettings(components=built_in, sample_period=H, platforms=("linux64",))
    vehicle = build_vehicle_fmu("full-vehicle", tmp_path / "car" / "full_vehicle.fmu", settings)
    ssd = write_ssd(
        connect_by_name("full vehicle", ("vehicle", vehicle), {}, tmp_path / "car"),
        tmp_path / "car" / "SystemStructure.ssd",
    )
    road = generate_drive(DriveSettings(duration=DURATION, seed=7))
    fade = fade_weights(len(road.time), H, 0.5)
    channels, units = {}, {}
    for c in corners:
        x = road[f"actuator_{c}_displacement"] * fade
        channels |= {f"actuator_{c}_displacement": x, f"actuator_{c}_velocity": np.gradient(x, H)}
        units |= {f"actuator_{c}_displacement": "m", f"actuator_{c}_velocity": "m/s"}
    known = Measurement(time=road.time, channels=channels, units=units, source="known four-post drive")
    with open_system(ssd) as structure:
        response = cosimulate(structure, known, CosimSettings(step=H, stop_time=float(known.time[-1]))).measurement
    save_measurement(
        Measurement(
            time=response.time,
            channels={c: response[c] for c in targets},
            units={c: response.units[c] for c in targets},
            source="road",
        ),
        tmp_path / "road.csv",
    )
    result = run_iterate(tmp_path / "road.csv", ssd, tmp_path / "out", replace(SETTINGS, iterations=15))
    assert result.converged and len(result.outcome.iterations) <= 15
    drive = read_drive(result.files["drive"])
    assert {f"actuator_{c}_displacement" for c in corners} <= set(drive.names)
    replay = run_cosim(ssd, result.files["drive"], CosimSettings(step=H)).measurement
    n = min(len(replay.time), len(response.time))
    best = result.outcome.iterations[result.outcome.best]
    for channel in targets:
        assert _nrmse(replay[channel][:n], response[channel][:n]) < 0.10, channel
        assert 0.8 <= best.metrics[channel]["pseudo_damage_ratio"] <= 1.25, channel
