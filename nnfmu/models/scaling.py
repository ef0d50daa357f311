"""Min-max scaling to [-1, 1] with the training set's extremes (the thesis's normalisation)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MinMaxScaler:
    """Affine map of each column from [lo, hi] to [-1, 1]: scaled = gain * (x - lo) - 1.

    A column with hi == lo (a constant) gets gain 1 so it maps to -1 instead of dividing by zero.
    """

    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def fit(cls, x: np.ndarray) -> "MinMaxScaler":
        """x: (n,) or (n, columns)."""
        x = np.asarray(x, dtype=np.float64)
        return cls(lo=np.min(x, axis=0), hi=np.max(x, axis=0))

    @property
    def gain(self) -> np.ndarray:
        span = np.asarray(self.hi - self.lo, dtype=np.float64)
        return np.where(span > 0, 2.0 / np.where(span > 0, span, 1.0), 1.0)

    def scale(self, x: np.ndarray) -> np.ndarray:
        return self.gain * (np.asarray(x, dtype=np.float64) - self.lo) - 1.0

    def unscale(self, s: np.ndarray) -> np.ndarray:
        return (np.asarray(s, dtype=np.float64) + 1.0) / self.gain + self.lo
