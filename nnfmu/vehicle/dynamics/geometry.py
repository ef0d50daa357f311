"""Left/right mirroring and bushing frames of the front suspension geometry (vehicle axes: x forward, y left, z up).

The right side is the left side's mirror image in the x-z plane. Points and translation directions mirror as polar
vectors (y negated); rotation directions mirror as axial vectors (x and z negated), so mirror-symmetric motion gives
equal deflections, rotations and LCA angles on both sides.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SIDES = {"l": 1.0, "r": -1.0}


def mirror_point(p: tuple[float, ...] | np.ndarray, side: float) -> np.ndarray:
    """Point or translation direction of the `side` (+1 left, -1 right) corner from its left-side value."""
    return np.array([1.0, side, 1.0]) * np.asarray(p, dtype=float)


def mirror_rotation(r: tuple[float, ...] | np.ndarray, side: float) -> np.ndarray:
    """Rotation direction of the `side` corner from its left-side value (an axial vector)."""
    return side * mirror_point(r, side)


def unit(v: tuple[float, ...] | np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class BushingFrame:
    """Orthonormal directions of one bushing: axis a, radial n (the given radial made normal to a), m = a x n.

    Translations are measured along (a, n, m); rotations about a (axial), about m (conical: tilts the axis towards n)
    and about n (the second conical direction, which has no port).
    """

    axis: np.ndarray
    radial: np.ndarray
    lateral: np.ndarray
    rot_axis: np.ndarray
    rot_conical: np.ndarray
    rot_lateral: np.ndarray

    @classmethod
    def of(cls, axis: tuple[float, ...], radial: tuple[float, ...], side: float) -> "BushingFrame":
        a = unit(axis)
        n = unit(np.asarray(radial, dtype=float) - np.dot(radial, a) * a)
        m = np.cross(a, n)
        return cls(
            axis=mirror_point(a, side),
            radial=mirror_point(n, side),
            lateral=mirror_point(m, side),
            rot_axis=mirror_rotation(a, side),
            rot_conical=mirror_rotation(m, side),
            rot_lateral=mirror_rotation(n, side),
        )
