"""Train/validation/test splits made of contiguous time blocks: neighbouring samples are correlated, so shuffled
samples would leak the test data into training. The record is cut into `blocks` equal segments and each segment is
split train/validation/test in time order, so every split sees every part of a test schedule (a dyno's sine series
runs from low to high velocity: one plain cut would leave the highest levels to the test split alone)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnfmu.errors import SettingsError


@dataclass(frozen=True)
class SplitFractions:
    """Share of every segment, in time order, given to training, validation (early stopping) and test; `blocks`:
    number of equal segments the record is cut into first (1 = one plain cut)."""

    train: float = 0.70
    validation: float = 0.15
    test: float = 0.15
    blocks: int = 10

    def __post_init__(self) -> None:
        for name in ("train", "validation", "test"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SettingsError(f"split fraction {name} must be a number > 0, got {value!r}")
        total = self.train + self.validation + self.test
        if abs(total - 1.0) > 1e-9:
            raise SettingsError(
                f"split fractions must add up to 1, got {self.train} + {self.validation} + {self.test} = {total}"
            )
        if isinstance(self.blocks, bool) or not isinstance(self.blocks, int) or self.blocks < 1:
            raise SettingsError(f"blocks must be an integer >= 1, got {self.blocks!r}")


@dataclass(frozen=True)
class Splits:
    """The sample ranges (Python slices, in time order) that make up each split."""

    train: tuple[slice, ...]
    validation: tuple[slice, ...]
    test: tuple[slice, ...]

    def items(self) -> list[tuple[str, tuple[slice, ...]]]:
        return [("train", self.train), ("validation", self.validation), ("test", self.test)]

    def index(self, split: str) -> np.ndarray:
        """Sample indices of one split ("train", "validation" or "test"), ascending."""
        return np.concatenate([np.arange(s.start, s.stop) for s in getattr(self, split)])

    def size(self, split: str) -> int:
        return sum(s.stop - s.start for s in getattr(self, split))


def contiguous_splits(n: int, fractions: SplitFractions = SplitFractions(), min_samples: int = 8) -> Splits:
    """Cut n samples into `fractions.blocks` segments, each into consecutive train, validation and test ranges.

    Raises SettingsError naming the split when any of its ranges would get fewer than `min_samples` samples.
    """
    parts: dict[str, list[slice]] = {"train": [], "validation": [], "test": []}
    edges = np.linspace(0, n, fractions.blocks + 1).round().astype(int)
    for lo, hi in zip(edges[:-1], edges[1:]):
        length = hi - lo
        n_train = int(round(length * fractions.train))
        n_validation = int(round(length * fractions.validation))
        cuts = {
            "train": (lo, lo + n_train),
            "validation": (lo + n_train, lo + n_train + n_validation),
            "test": (lo + n_train + n_validation, hi),
        }
        for name, (start, stop) in cuts.items():
            if stop - start < min_samples:
                raise SettingsError(
                    f"{n} samples in {fractions.blocks} block(s) give the {name} split only {stop - start} samples per "
                    f"block (at least {min_samples} needed); use a longer record, fewer blocks or other split fractions"
                )
            parts[name].append(slice(int(start), int(stop)))
    return Splits(train=tuple(parts["train"]), validation=tuple(parts["validation"]), test=tuple(parts["test"]))
