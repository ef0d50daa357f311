"""Cut one record into fit, diagnosis and test parts, so that the diagnosis and the reported error never see data a
network was fitted on. Each of `segments` equal segments is split in time order: fit (training, then validation for
early stopping), diagnosis, test; so every part sees every stretch of the record (a lab schedule's sine series as
well as its random drive, a damper's cold start as well as its warm end)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.data import Measurement
from nnfmu.workflows.loop.errors import LoopError
from nnfmu.workflows.loop.settings import LoopSettings

PARTS = ("train", "validation", "diagnosis", "test")


@dataclass(frozen=True)
class RecordBlocks:
    """Sample ranges (start, stop) of each part, in time order."""

    ranges: dict[str, tuple[tuple[int, int], ...]]

    def rows(self, part: str) -> np.ndarray:
        """Sample indices of one part, ascending."""
        return np.concatenate([np.arange(a, b) for a, b in self.ranges[part]])

    def describe(self, time: np.ndarray) -> dict[str, list[list[float]]]:
        """Each part's time spans [s] for the report."""
        return {part: [[float(time[a]), float(time[b - 1])] for a, b in spans] for part, spans in self.ranges.items()}


def plan_blocks(n: int, settings: LoopSettings, source: str) -> RecordBlocks:
    """The parts of an n-sample record; LoopError naming `source` when the diagnosis part would be shorter than the
    diagnosis needs."""
    edges = np.linspace(0, n, settings.segments + 1).round().astype(int)
    ranges: dict[str, list[tuple[int, int]]] = {part: [] for part in PARTS}
    for lo, hi in zip(edges[:-1], edges[1:]):
        length = hi - lo
        cuts = np.round(
            lo
            + length
            * np.array(
                [
                    settings.fit_fraction - settings.validation_fraction,
                    settings.fit_fraction,
                    1.0 - settings.test_fraction,
                ]
            )
        ).astype(int)
        for part, a, b in zip(PARTS, (lo, *cuts), (*cuts, hi)):
            ranges[part].append((int(a), int(b)))
    blocks = RecordBlocks({part: tuple(spans) for part, spans in ranges.items()})
    need = settings.diagnosis.min_samples
    diagnosis = len(blocks.rows("diagnosis"))
    if diagnosis < need or any(b - a < 2 for spans in blocks.ranges.values() for a, b in spans):
        share = 1.0 - settings.fit_fraction - settings.test_fraction
        raise LoopError(
            f"{source}: {n} samples are too short for the loop: the diagnosis part ({share:.0%} of the record) gets "
            f"{diagnosis} samples, at least {need} are needed (DiagnosisSettings.min_samples); record at least "
            f"{int(np.ceil(need / share))} samples"
        )
    return blocks


def part_measurement(m: Measurement, rows: np.ndarray, name: str) -> Measurement:
    """The samples `rows` of `m` joined into one record on a uniform time axis from the first row's time."""
    time = m.time[rows[0]] + np.arange(len(rows)) * m.sample_period
    return Measurement(
        time=time,
        channels={k: np.asarray(v)[rows].copy() for k, v in m.channels.items()},
        units=dict(m.units),
        source=f"{m.source} ({name} part)",
        notes=dict(m.notes),
    )


def training_part(m: Measurement, settings: LoopSettings) -> Measurement:
    """The record's training blocks joined: what a first model may be fitted on so that the loop's diagnosis and
    test blocks of the same record stay unseen."""
    return part_measurement(m, plan_blocks(len(m), settings, m.source).rows("train"), "fit")
