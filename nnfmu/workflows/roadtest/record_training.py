"""Train presets on one vehicle-derived rig record: the step the bushing and the damper drives share."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from nnfmu.workflows.train import TrainRequest, train_from_file


def train_on_record(
    rig: Path,
    presets: Sequence[str],
    request: Callable[[str], TrainRequest],
    folder: Path,
    seconds: dict[str, float],
    log: Callable[[str], None],
) -> dict[str, Path]:
    """Each preset trained on the record `rig` with `request(preset)` into `folder/<preset>.onnx`; its training time
    [s] goes into `seconds` and its notes on the feature spec into `log`; returns the ONNX file per preset."""
    models: dict[str, Path] = {}
    for preset in presets:
        trained = train_from_file(rig, request(preset), folder / f"{preset}.onnx")
        models[preset] = trained.path
        seconds[preset] = trained.seconds
        log(
            f"{preset} on the vehicle-derived record: trained in {trained.seconds:.1f} s, test-split NRMSE "
            f"{trained.metrics['test'].nrmse:.2%}"
        )
        for note in trained.training_notes:
            log(f"{preset}: note: {note}")
    return models
