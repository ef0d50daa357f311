"""A uniform time base fitted to a record's stamps: rounding and a clock's scatter accepted, gaps and drift refused.

nnfmu trains on uniformly sampled records, t_k = t_0 + k·T. Files store rounded stamps: a controller printing 8
significant digits resolves 1e-7 s on [1, 10) s, 1e-6 s on [10, 100) s (0.1 % of a 1024 Hz period) and 1e-5 s
beyond. `t_0` and `T` are fitted by least squares over all stamps, and each stamp may lie off that line by its
tolerance, the largest of
- print rounding: half its resolution (one unit in the last digit the file's format prints at the stamp's
  magnitude, inferred per file from the stamps' text by `printed_resolution`), plus RESOLUTION_SIGMAS standard
  deviations of the fitted line itself under that rounding (the line is estimated from rounded stamps too);
  binary stamps (MDF) have no print rounding, except a float32 time channel, resolved to the float32 spacing;
- a clock's scatter: CLOCK_SCATTER (5 %) of the period, for every record. A controller that keeps time in a 32-bit
  float stores each stamp to 2^-23 of its value (1.9 us at 16-32 s, 3.8 us at 32-64 s, 7.6 us at 64-128 s) before it
  prints it, so its stamps scatter by up to 0.4 % of a 1024 Hz period about the line, more than print rounding
  explains; so does a clock with a few per cent of sampling jitter. A missing sample moves the stamps after it by a
  whole period, a clock whose rate drifts moves them ever farther: both lie far beyond 5 %;
- float64 noise: FLOAT_NOISE units of float64 epsilon of the largest stamp.
Rounding to nearest is assumed; a controller that truncates is covered as far as the clock's scatter reaches.

A record whose stamps all lie within float64 noise of the line keeps them as stored. Otherwise `uniform_stamps` replaces
them by the fitted base and notes in one line how far they strayed and which tolerance covered it (a scatter beyond
TIME_JITTER of the period that the resolution does not explain is named as a clock's, with the float32 spacing at the
last stamp for comparison). A stamp beyond its tolerance is refused, naming the sample: the first step that differs
from the median step by more than its two stamps' tolerances (a gap or a jump), else the stamp farthest off the line
(a clock whose rate drifts, or a stamp out of line). `Measurement` keeps stamps within TIME_JITTER of their base as
given and takes the fitted base (with the note) for those scattering farther (`measurement_axis`), so it accepts
exactly what the loaders accept.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from nnfmu.data.errors import DataError

TIME_JITTER = 1e-3  # sampling jitter a Measurement keeps its stamps for, relative to the period
CLOCK_SCATTER = 0.05  # scatter about the fitted base accepted at every stamp, relative to the period
FLOAT_NOISE = 64.0  # float64 rounding accepted at every stamp, in units of epsilon times the largest |stamp|
RESOLUTION_SIGMAS = 3.0  # standard deviations of the fitted line's own rounding error added to half the resolution


@dataclass(frozen=True)
class Resolution:
    """How finely a file stores each time stamp: `step` [file's time unit] per stamp, shape (n,), and a description."""

    step: np.ndarray
    format: str

    def scaled(self, factor: float) -> "Resolution":
        """The same resolution in another time unit (`factor` = new units per old unit; itself for 1)."""
        return self if factor == 1.0 else Resolution(step=self.step * factor, format=self.format)


def _digits(text: str) -> tuple[int, int] | None:
    """(significant digits, decimals) as printed in one number's text; None for a zero or not a plain number."""
    mantissa, _, exponent_text = text.strip().lstrip("+-").upper().partition("E")
    whole, _, fraction = mantissa.partition(".")
    digits = whole + fraction
    if not digits.isdigit() or not digits.isascii():
        return None
    try:
        exponent = int(exponent_text) if exponent_text else 0
    except ValueError:
        return None
    significant = digits.lstrip("0")
    if not significant:
        return None
    return len(significant), len(fraction) - exponent


def printed_digits(cells: Iterable[str]) -> tuple[int, int] | None:
    """(most significant digits, most decimals) any of the stamps printed as `cells` shows, or None if no cell shows
    a digit; what `printed_resolution` infers the file's format from, gathered a chunk of cells at a time by
    `combine_digits`."""
    found = None
    for counts in map(_digits, cells):
        if counts is not None:
            found = counts if found is None else (max(found[0], counts[0]), max(found[1], counts[1]))
    return found


def combine_digits(a: tuple[int, int] | None, b: tuple[int, int] | None) -> tuple[int, int] | None:
    """The `printed_digits` of two runs of cells together."""
    if a is None or b is None:
        return a if b is None else b
    return max(a[0], b[0]), max(a[1], b[1])


def printed_resolution(cells: Sequence[str], values: np.ndarray) -> Resolution | None:
    """The resolution of time stamps printed as `cells` (their text) with the parsed `values`, or None if no cell
    shows a digit (`digits_resolution` of `printed_digits`)."""
    return digits_resolution(printed_digits(cells), values)


def digits_resolution(digits: tuple[int, int] | None, values: np.ndarray) -> Resolution | None:
    """The resolution of stamps `values` printed with `digits` = (S, D) from `printed_digits`, or None.

    The file's format is inferred from all cells: the most significant digits any stamp shows (S, for `%.8g`-style
    stamps whose last digit moves with the magnitude) and the most decimals (D, for fixed-decimal stamps). A stamp's
    resolution is the coarser of 10^-D and one unit in its S-th significant digit, which is the format's own
    resolution whichever of the two styles the file uses (trailing zeros a `%g` format drops do not count against it).
    """
    if digits is None:
        return None
    significant, decimals = digits
    magnitude = np.abs(np.asarray(values, dtype=float))
    exponent = np.floor(np.log10(np.where(magnitude > 0, magnitude, 1.0)))
    by_digits = np.where(magnitude > 0, 10.0 ** (exponent - significant + 1), 0.0)
    del exponent, magnitude
    step = np.maximum(10.0**-decimals, by_digits)
    coarser_by_digits = step.size > 0 and float(np.max(by_digits)) > 10.0**-decimals
    style = f"{significant} significant digits" if coarser_by_digits else f"{decimals} decimals"
    return Resolution(step=step, format=f"printed to {style}")


def float32_resolution(values: np.ndarray) -> Resolution:
    """The resolution of stamps stored as float32: the float32 spacing at each stamp."""
    spacing = np.spacing(np.abs(np.asarray(values, dtype=np.float32))).astype(np.float64)
    return Resolution(step=spacing, format="stored as float32")


@dataclass(frozen=True)
class UniformFit:
    """The least-squares base t_k = start + k·period [s] of n stamps, each stamp's deviation from it and tolerance."""

    start: float
    period: float
    deviation: np.ndarray
    tolerance: np.ndarray
    noise: float

    @property
    def exact(self) -> bool:
        """True when every stamp lies within float64 noise of the base (nothing to replace)."""
        return bool(np.max(np.abs(self.deviation)) <= self.noise)

    def times(self) -> np.ndarray:
        """The fitted base itself, shape (n,)."""
        return self.start + np.arange(self.deviation.size) * self.period


def _g(value: float) -> str:
    """A number for a message: 10 significant digits, no numpy type name."""
    return f"{float(value):.10g}"


def _rounding(resolution: Resolution) -> np.ndarray:
    """Half of each stamp's resolution plus RESOLUTION_SIGMAS standard deviations of a line fitted by least squares
    to stamps carrying independent rounding errors, uniform over one resolution step (variance step²/12)."""
    step = resolution.step
    n = step.size
    variance = float(np.dot(step, step)) / max(n, 1) / 12.0
    spread = np.arange(n, dtype=float)  # k, then the line's standard deviation at k, in place (one array of n)
    spread -= (n - 1) / 2.0
    sum_k2 = max(float(np.dot(spread, spread)), 1.0)
    np.square(spread, out=spread)
    spread *= variance / sum_k2
    spread += variance / max(n, 1)
    np.sqrt(spread, out=spread)
    spread *= RESOLUTION_SIGMAS
    spread += 0.5 * step
    return spread


def stamp_tolerance(time: np.ndarray, period: float, resolution: Resolution | None = None) -> np.ndarray:
    """How far each stamp of `time` [s] may lie off a uniform base of `period` [s]: the module docstring's rule."""
    time = np.asarray(time, dtype=float)
    noise = FLOAT_NOISE * np.finfo(float).eps * float(np.max(np.abs(time), initial=0.0))
    floor = max(CLOCK_SCATTER * abs(period), noise)
    if resolution is None:
        return np.full(time.size, floor)
    tolerance = _rounding(resolution)
    return np.maximum(tolerance, floor, out=tolerance)


def fit_uniform(time: np.ndarray, resolution: Resolution | None = None) -> UniformFit:
    """Fit t_k = start + k·period to `time` (shape (n,), n >= 2, in s) by least squares; tolerances as documented."""
    time = np.asarray(time, dtype=float)
    n = time.size
    k = np.arange(n, dtype=float)
    k -= (n - 1) / 2.0
    offset = time - time[0]  # fitting relative to the first stamp keeps the sums well conditioned
    mean = float(np.mean(offset))
    offset -= mean
    period = float(np.dot(k, offset) / np.dot(k, k))
    k *= period
    offset -= k  # the deviation, in place: offset - mean - k * period
    deviation = offset
    del k
    noise = FLOAT_NOISE * np.finfo(float).eps * float(np.max(np.abs(time)))
    tolerance = stamp_tolerance(time, period, resolution)
    start = float(time[0] + mean - period * (n - 1) / 2.0)
    return UniformFit(start=start, period=period, deviation=deviation, tolerance=tolerance, noise=noise)


def _tolerance_text(fit: UniformFit, row: int, resolution: Resolution | None) -> str:
    """Which tolerance applies at one stamp, for an error message."""
    jitter = f"{CLOCK_SCATTER:g} of the period (a clock's scatter)"
    if resolution is None:
        return jitter
    return (
        f"the larger of {jitter} and {_g(_rounding(resolution)[row])} s for the stamp's "
        f"resolution {_g(resolution.step[row])} s ({resolution.format})"
    )


def check_uniform(time: np.ndarray, where: str, resolution: Resolution | None = None) -> UniformFit | None:
    """Raise DataError naming `where` and the sample unless `time` [s] is finite, increases and is uniform within
    tolerance.

    Returns the fit (None for fewer than two stamps).
    """
    time = np.asarray(time, dtype=float)
    not_finite = np.flatnonzero(~np.isfinite(time))
    if not_finite.size:
        row = int(not_finite[0])
        raise DataError(f"{where}: time is {_g(time[row])} at sample {row}")
    if time.size < 2:
        return None
    steps = np.diff(time)
    not_increasing = np.flatnonzero(steps <= 0)
    if not_increasing.size:
        row = int(not_increasing[0]) + 1
        raise DataError(
            f"{where}: time does not increase at sample {row}: t = {_g(time[row - 1])} s then {_g(time[row])} s"
        )
    fit = fit_uniform(time, resolution)
    if np.all(np.abs(fit.deviation) <= fit.tolerance):
        return fit
    off = np.abs(fit.deviation) > fit.tolerance
    median = float(np.median(steps))
    jumps = np.flatnonzero(np.abs(steps - median) > fit.tolerance[1:] + fit.tolerance[:-1])
    if jumps.size:
        row = int(jumps[0]) + 1
        raise DataError(
            f"{where}: time is not uniformly sampled at sample {row} (t = {_g(time[row])} s): the step from the "
            f"previous sample is {_g(steps[row - 1])} s, the period {_g(median)} s (each stamp may be off by "
            f"{_tolerance_text(fit, row, resolution)})"
        )
    row = int(np.argmax(np.abs(fit.deviation) / fit.tolerance))
    raise DataError(
        f"{where}: time is not uniformly sampled at sample {row} (t = {_g(time[row])} s): the stamp lies "
        f"{fit.deviation[row]:.3g} s off the least-squares uniform base t = {_g(fit.start)} s + k * "
        f"{_g(fit.period)} s, "
        f"farther than {_tolerance_text(fit, row, resolution)}; {int(off.sum())} of {time.size} stamps lie beyond "
        f"their tolerance (a sampling clock that drifts, or stamps out of line)"
    )


def _note(fit: UniformFit, resolution: Resolution | None) -> str:
    """One line: how far the stamps strayed, which tolerance covered it, and the base the record now uses."""
    worst = float(np.max(np.abs(fit.deviation)))
    resolved = resolution is not None and bool(
        np.all(np.abs(fit.deviation) <= np.maximum(_rounding(resolution), fit.noise))
    )
    if resolved:
        why = f"within their resolution ({resolution.format}; {_g(resolution.step[-1])} s at the last stamp)"
    elif worst <= TIME_JITTER * fit.period:
        why = f"within the sampling jitter of {TIME_JITTER:g} of the period"
    else:
        last = float(np.spacing(np.float32(abs(fit.times()[-1]))))
        explains = f"their resolution ({resolution.format})" if resolution is not None else "sampling jitter"
        why = (
            f"more than {explains} explains but within the {CLOCK_SCATTER:g} of the period nnfmu accepts as a "
            f"clock's scatter (a clock keeping time as a 32-bit float resolves 2^-23 of the time, {last:.3g} s at the "
            f"last stamp, and its stamps look like this)"
        )
    return (
        f"time stamps deviate from a uniform base by up to {worst:.3g} s ({worst / fit.period:.3%} of the period), "
        f"{why}; the record uses the least-squares base t = {_g(fit.start)} s + k * {_g(fit.period * 1e3)} ms "
        f"({_g(1.0 / fit.period)} Hz) instead of the stamps"
    )


def uniform_stamps(time: np.ndarray, where: str, resolution: Resolution | None = None) -> tuple[np.ndarray, str | None]:
    """`time` [s] itself and None when its stamps are exact, else its fitted uniform base and a one-line note saying so.

    Raises DataError naming `where` (see `check_uniform`) when the stamps are not uniform within tolerance.
    """
    fit = check_uniform(time, where, resolution)
    if fit is None or fit.exact:
        return time, None
    return fit.times(), _note(fit, resolution)


def measurement_axis(time: np.ndarray, where: str) -> tuple[np.ndarray, str | None]:
    """A `Measurement`'s axis: `time` [s] itself and None when every stamp lies within TIME_JITTER of the period of
    its fitted base, else the base and a one-line note; DataError naming `where` as `check_uniform` raises it."""
    fit = check_uniform(time, where)
    if fit is None or float(np.max(np.abs(fit.deviation))) <= max(TIME_JITTER * fit.period, fit.noise):
        return time, None
    return fit.times(), _note(fit, None)
