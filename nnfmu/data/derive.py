"""Rates that a rig did not measure, differentiated from the measured signals with a Savitzky-Golay filter.

Why Savitzky-Golay: a finite difference amplifies measurement noise by 1/dt per derivative; a local polynomial fit
over a short window differentiates the signal in the rig's band almost exactly and suppresses the noise above it.
Settings: polynomial order POLYORDER over about WINDOW_S seconds, rounded to an odd number of samples, at least
MIN_WINDOW. From 1 kHz sampling up, the gain error is below 0.1 % up to 40 Hz (the thesis's rig controller cut-off)
for the first and for the second derivative, and below 3 % at 100 Hz. The ends use the polynomial fitted to the
first/last window (`mode="interp"`), so no sample is lost.

Rules, for every direction prefix `p` (`axial_`, `conical_`, or none), applied only where the target is missing:
- `p+velocity` = d/dt `p+displacement`;
- `p+acceleration` = d/dt `p+velocity` where velocity was measured, else d²/dt² `p+displacement`;
- `p+angular_velocity` = d/dt `p+rotation`.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter

from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.units import base_name, si_unit_of

WINDOW_S = 0.005
POLYORDER = 4
MIN_WINDOW = 7


def window_length(sample_period: float) -> int:
    """Odd number of samples spanning about WINDOW_S at this sample period [s], at least MIN_WINDOW."""
    samples = int(round(WINDOW_S / sample_period)) // 2 * 2 + 1
    return max(samples, MIN_WINDOW)


def _window(n: int, sample_period: float) -> int:
    """The window actually used for `n` samples: window_length, shrunk to the largest odd number <= n if needed."""
    if n <= POLYORDER:
        raise DataError(f"{n} samples are too few to differentiate (at least {POLYORDER + 1} needed)")
    return min(window_length(sample_period), n - (1 - n % 2))


def derivative(values: np.ndarray, sample_period: float, order: int) -> np.ndarray:
    """The `order`-th time derivative of uniformly sampled `values` (shape (n,)), in units per second**order.

    Raises DataError when there are fewer than POLYORDER + 1 samples to fit.
    """
    window = _window(len(values), sample_period)
    return savgol_filter(values, window, POLYORDER, deriv=order, delta=sample_period, mode="interp")


def _rules(names: list[str]) -> list[tuple[str, str, int]]:
    """(target, source, derivative order) for every rate to derive from the channels `names`."""
    present = set(names)
    rules: list[tuple[str, str, int]] = []
    for name in names:
        base = base_name(name)
        prefix = name[: len(name) - len(base)] if base else ""
        if base == "displacement":
            rules.append((prefix + "velocity", name, 1))
            if prefix + "velocity" not in present:
                rules.append((prefix + "acceleration", name, 2))
        elif base == "velocity":
            rules.append((prefix + "acceleration", name, 1))
        elif base == "rotation":
            rules.append((prefix + "angular_velocity", name, 1))
    return [(target, source, order) for target, source, order in rules if target not in present]


def derive_rates(m: Measurement) -> Measurement:
    """A copy of `m` with the missing rates added (see the module docstring) and each recorded in `notes`.

    A derived channel `x` gets the note `notes["derived:x"]` saying from what and how. `m` must be uniformly
    sampled (check it first with `check_measurement`).
    """
    channels = dict(m.channels)
    units = dict(m.units)
    notes = dict(m.notes)
    rules = _rules(list(m.channels))
    if rules and len(m.time) <= POLYORDER:
        target, source, _ = rules[0]
        raise DataError(
            f"{m.source}: cannot derive {target!r} from {source!r}: {len(m.time)} samples, "
            f"at least {POLYORDER + 1} needed"
        )
    for target, source, order in rules:
        window = _window(len(m.time), m.sample_period)
        channels[target] = derivative(np.asarray(m.channels[source], dtype=float), m.sample_period, order)
        units[target] = si_unit_of(target)
        how = "d/dt" if order == 1 else f"d{order}/dt{order}"
        notes[f"derived:{target}"] = (
            f"{how} of {source!r} by a Savitzky-Golay filter "
            f"(polynomial order {POLYORDER}, window {window} samples = {window * m.sample_period * 1e3:.3g} ms)"
        )
    return Measurement(time=m.time, channels=channels, units=units, source=m.source, notes=notes)
