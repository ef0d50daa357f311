"""Bushing networks trained on a vehicle-derived rig record: source reference on its own drive seed, rig record
derived from all four front LCA bushings, the four presets trained on it, their envelope covering the source."""

from __future__ import annotations

import json

import numpy as np
import onnx
import pytest

from nnfmu.component import Component
from nnfmu.data import load_measurement
from nnfmu.data.drive_files import read_drive
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.roadtest import (
    BUSHING_MODELS,
    BushingDriveSettings,
    RoadTestError,
    RoadTestSettings,
    VehicleBushingModels,
    train_vehicle_bushings,
)
from nnfmu.workflows.roadtest.systems import bushing_elements
from nnfmu.workflows.train import TrainRequest


@pytest.fixture(scope="module")
def vehicle_bushings(tmp_path_factory: pytest.TempPathFactory) -> VehicleBushingModels:
    settings = BushingDriveSettings(duration=0.5, rig_duration=6.0, margin=1.3)
    return train_vehicle_bushings(
        tmp_path_factory.mktemp("vehicle_bushing"),
        RoadTestSettings(seed=4),
        settings,
        lambda preset: TrainRequest(preset=preset, restarts=1, max_epochs=3, hidden=(3,)),
        log=lambda _: None,
    )


def test_source_runs_on_its_own_drive_seed_and_the_record_names_it(vehicle_bushings: VehicleBushingModels) -> None:
    drive = read_drive(vehicle_bushings.drive)
    fade = RoadTestSettings().fade_in  # the road test's drives start from rest
    own = generate_drive(DriveSettings(seed=5, duration=0.501, fade_in=fade))  # the road test's seed 4 plus the offset
    road = generate_drive(DriveSettings(seed=4, duration=0.501, fade_in=fade))
    for channel in own.names:
        assert np.allclose(drive[channel], own[channel], rtol=1e-6, atol=1e-9)
        assert not np.allclose(drive[channel], road[channel], rtol=1e-3, atol=1e-6)
    truth = json.loads(vehicle_bushings.truth.read_text())
    drives = truth["excitation"]["drives"]
    assert drives["source"] == str(vehicle_bushings.source)
    assert drives["elements"] == bushing_elements("full-vehicle")
    assert drives["design"]["margin"] == 1.3


def test_every_bushing_network_covers_the_source_deflections_of_all_four_bushings(
    vehicle_bushings: VehicleBushingModels,
) -> None:
    assert sorted(vehicle_bushings.models) == sorted(BUSHING_MODELS)
    source = load_measurement(vehicle_bushings.source)
    for preset, path in vehicle_bushings.models.items():
        component = Component.from_onnx(onnx.load(path))
        position = component.inputs[0]  # the preset's first input is its channel's deflection
        assert position.name.endswith(("displacement", "rotation")), preset
        for element in bushing_elements("full-vehicle"):
            signal = source[f"{element}_{position.name}"]
            # the drive reaches margin x the simulated excursions; the recorded (noisy) envelope still holds them
            assert position.min <= signal.min() and signal.max() <= position.max, (preset, element)


def test_source_drive_must_differ_from_the_road_tests() -> None:
    with pytest.raises(RoadTestError, match="seed_offset"):
        BushingDriveSettings(seed_offset=0)
