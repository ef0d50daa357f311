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

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from nnfmu.data.errors import DataError

TIME_JITTER = 1e-3  # sampling jitter a Measurement keeps its stamps for, relative to the period
CLOCK_SCATTER = 0.05  # scatter about the fitted base accepted at every stamp, relative to the period
FLOAT_NOISE = 64.0  # float64 rounding accepted at every stamp, in units of epsilon times the largest |stamp|
RESOLUTION_SIGMAS = 3.0  # standard deviations of the fitted line's own rounding error added to half the resolution
CHUNK = 1 << 16  # stamps handled at a time (512 kB of float64), so no check holds a temporary of the record's length


def _spans(n: int) -> Iterator[tuple[int, int]]:
    """(lo, hi) of consecutive runs of at most CHUNK of n stamps."""
    return ((lo, min(n, lo + CHUNK)) for lo in range(0, n, CHUNK))


def _largest_magnitude(values: np.ndarray) -> float:
    """max |values| (0 for none) without a temporary array."""
    return float(max(-np.min(values), np.max(values))) if values.size else 0.0


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
    values = np.asarray(values, dtype=float)
    step = np.empty(values.size)
    coarsest = -np.inf  # the largest resolution by digits, computed a chunk at a time
    for lo, hi in _spans(values.size):
        magnitude = np.abs(values[lo:hi])
        exponent = np.floor(np.log10(np.where(magnitude > 0, magnitude, 1.0)))
        by_digits = np.where(magnitude > 0, 10.0 ** (exponent - significant + 1), 0.0)
        coarsest = max(coarsest, float(np.max(by_digits)))
        np.maximum(10.0**-decimals, by_digits, out=step[lo:hi])
    coarser_by_digits = step.size > 0 and coarsest > 10.0**-decimals
    style = f"{significant} significant digits" if coarser_by_digits else f"{decimals} decimals"
    return Resolution(step=step, format=f"printed to {style}")


def float32_resolution(values: np.ndarray) -> Resolution:
    """The resolution of stamps stored as float32: the float32 spacing at each stamp."""
    values = np.asarray(values)
    spacing = np.empty(values.size)
    for lo, hi in _spans(values.size):
        spacing[lo:hi] = np.spacing(np.abs(values[lo:hi].astype(np.float32)))
    return Resolution(step=spacing, format="stored as float32")


def _centred(lo: int, hi: int, n: int) -> np.ndarray:
    """k - (n - 1) / 2 for the stamps k = lo..hi-1 of n: the sample index about the record's centre."""
    k = np.arange(lo, hi, dtype=float)
    k -= (n - 1) / 2.0
    return k


@dataclass(frozen=True)
class _Rounding:
    """Half of each stamp's resolution `step` plus RESOLUTION_SIGMAS standard deviations of a line fitted by least
    squares to stamps carrying independent rounding errors, uniform over one resolution step (`variance` step²/12;
    `sum_k2`: the sum of the squared centred indices), a span of stamps at a time."""

    step: np.ndarray
    variance: float
    sum_k2: float

    @classmethod
    def of(cls, resolution: Resolution) -> "_Rounding":
        step = resolution.step
        n = step.size
        squares, sum_k2 = 0.0, 0.0
        for lo, hi in _spans(n):
            part, k = step[lo:hi], _centred(lo, hi, n)
            squares += float(np.dot(part, part))
            sum_k2 += float(np.dot(k, k))
        return cls(step=step, variance=squares / max(n, 1) / 12.0, sum_k2=max(sum_k2, 1.0))

    def at(self, lo: int, hi: int) -> np.ndarray:
        """The rounding tolerance of stamps lo..hi-1 [s]."""
        n = self.step.size
        spread = _centred(lo, hi, n)  # then the line's standard deviation at k, in place
        np.square(spread, out=spread)
        spread *= self.variance / self.sum_k2
        spread += self.variance / max(n, 1)
        np.sqrt(spread, out=spread)
        spread *= RESOLUTION_SIGMAS
        spread += 0.5 * self.step[lo:hi]
        return spread


@dataclass(frozen=True)
class _Tolerance:
    """How far each stamp may lie off a uniform base (the module docstring's rule): at least `floor` [s] (a clock's
    scatter, float64 noise), more where the print `rounding` says so; a span of stamps at a time."""

    floor: float
    rounding: _Rounding | None

    def at(self, lo: int, hi: int) -> np.ndarray:
        """The tolerance of stamps lo..hi-1 [s]."""
        if self.rounding is None:
            return np.full(hi - lo, self.floor)
        tolerance = self.rounding.at(lo, hi)
        return np.maximum(tolerance, self.floor, out=tolerance)


def _tolerance(time: np.ndarray, period: float, resolution: Resolution | None) -> _Tolerance:
    noise = FLOAT_NOISE * np.finfo(float).eps * _largest_magnitude(time)
    floor = max(CLOCK_SCATTER * abs(period), noise)
    return _Tolerance(floor, None if resolution is None else _Rounding.of(resolution))


def stamp_tolerance(time: np.ndarray, period: float, resolution: Resolution | None = None) -> np.ndarray:
    """How far each stamp of `time` [s] may lie off a uniform base of `period` [s]: the module docstring's rule."""
    time = np.asarray(time, dtype=float)
    return _tolerance(time, period, resolution).at(0, time.size)


@dataclass(frozen=True)
class UniformFit:
    """The least-squares base t_k = start + k·period [s] of the n stamps `time`, the largest deviation of a stamp
    from it (`worst` [s]) and float64 `noise` [s]; each stamp's deviation and tolerance are computed a span at a time
    (`deviation`, `tolerance`), so a fit holds no array of the record's length beside the stamps."""

    start: float
    period: float
    noise: float
    worst: float
    time: np.ndarray
    mean: float  # mean of time - time[0], the line's value at the record's centre
    limits: _Tolerance

    @property
    def exact(self) -> bool:
        """True when every stamp lies within float64 noise of the base (nothing to replace)."""
        return self.worst <= self.noise

    def deviation(self, lo: int = 0, hi: int | None = None) -> np.ndarray:
        """How far stamps lo..hi-1 (default: all) lie off the base [s]: t - t_0 - mean - (k - (n-1)/2)·period."""
        hi = self.time.size if hi is None else hi
        offset = self.time[lo:hi] - self.time[0]  # relative to the first stamp, as fitted
        offset -= self.mean
        k = _centred(lo, hi, self.time.size)
        k *= self.period
        offset -= k
        return offset

    def tolerance(self, lo: int = 0, hi: int | None = None) -> np.ndarray:
        """How far stamps lo..hi-1 (default: all) may lie off the base [s]."""
        return self.limits.at(lo, self.time.size if hi is None else hi)

    def last(self) -> float:
        """The base's last stamp [s]."""
        return self.start + (self.time.size - 1) * self.period

    def times(self) -> np.ndarray:
        """The fitted base itself, shape (n,)."""
        base = np.arange(self.time.size, dtype=float)
        base *= self.period
        base += self.start
        return base


def _g(value: float) -> str:
    """A number for a message: 10 significant digits, no numpy type name."""
    return f"{float(value):.10g}"


def fit_uniform(time: np.ndarray, resolution: Resolution | None = None) -> UniformFit:
    """Fit t_k = start + k·period to `time` (shape (n,), n >= 2, in s) by least squares; tolerances as documented.
    The sums run a chunk of stamps at a time, relative to the first stamp (well conditioned)."""
    time = np.asarray(time, dtype=float)
    n = time.size
    first = time[0]
    total = 0.0
    for lo, hi in _spans(n):
        total += float(np.sum(time[lo:hi] - first))
    mean = total / n
    along, sum_k2 = 0.0, 0.0
    for lo, hi in _spans(n):
        offset, k = time[lo:hi] - first, _centred(lo, hi, n)
        offset -= mean
        along += float(np.dot(k, offset))
        sum_k2 += float(np.dot(k, k))
    period = along / sum_k2
    noise = FLOAT_NOISE * np.finfo(float).eps * _largest_magnitude(time)
    start = float(first + mean - period * (n - 1) / 2.0)
    fit = UniformFit(start, period, noise, 0.0, time, mean, _tolerance(time, period, resolution))
    return replace(fit, worst=max(float(np.max(np.abs(fit.deviation(lo, hi)))) for lo, hi in _spans(n)))


def _tolerance_text(fit: UniformFit, row: int, resolution: Resolution | None) -> str:
    """Which tolerance applies at one stamp, for an error message."""
    jitter = f"{CLOCK_SCATTER:g} of the period (a clock's scatter)"
    if resolution is None or fit.limits.rounding is None:
        return jitter
    return (
        f"the larger of {jitter} and {_g(fit.limits.rounding.at(row, row + 1)[0])} s for the stamp's "
        f"resolution {_g(resolution.step[row])} s ({resolution.format})"
    )


def _refuse_not_finite_or_increasing(time: np.ndarray, where: str) -> None:
    """DataError naming `where` and the first stamp that is not finite, else the first that does not increase;
    a chunk of stamps at a time."""
    for lo, hi in _spans(time.size):
        bad = np.flatnonzero(~np.isfinite(time[lo:hi]))
        if bad.size:
            row = lo + int(bad[0])
            raise DataError(f"{where}: time is {_g(time[row])} at sample {row}")
    for lo, hi in _spans(time.size - 1):
        bad = np.flatnonzero(np.diff(time[lo : hi + 1]) <= 0)  # the steps into stamps lo+1..hi
        if bad.size:
            row = lo + int(bad[0]) + 1
            raise DataError(
                f"{where}: time does not increase at sample {row}: t = {_g(time[row - 1])} s then {_g(time[row])} s"
            )


def check_uniform(time: np.ndarray, where: str, resolution: Resolution | None = None) -> UniformFit | None:
    """Raise DataError naming `where` and the sample unless `time` [s] is finite, increases and is uniform within
    tolerance.

    Returns the fit (None for fewer than two stamps). An accepted record is checked a chunk of stamps at a time; only
    a refusal looks at all stamps at once, to name the one at fault.
    """
    time = np.asarray(time, dtype=float)
    _refuse_not_finite_or_increasing(time, where)
    if time.size < 2:
        return None
    fit = fit_uniform(time, resolution)
    off = sum(
        int(np.count_nonzero(np.abs(fit.deviation(lo, hi)) > fit.tolerance(lo, hi))) for lo, hi in _spans(time.size)
    )
    if not off:
        return fit
    deviation, tolerance, steps = fit.deviation(), fit.tolerance(), np.diff(time)
    median = float(np.median(steps))
    jumps = np.flatnonzero(np.abs(steps - median) > tolerance[1:] + tolerance[:-1])
    if jumps.size:
        row = int(jumps[0]) + 1
        raise DataError(
            f"{where}: time is not uniformly sampled at sample {row} (t = {_g(time[row])} s): the step from the "
            f"previous sample is {_g(steps[row - 1])} s, the period {_g(median)} s (each stamp may be off by "
            f"{_tolerance_text(fit, row, resolution)})"
        )
    row = int(np.argmax(np.abs(deviation) / tolerance))
    raise DataError(
        f"{where}: time is not uniformly sampled at sample {row} (t = {_g(time[row])} s): the stamp lies "
        f"{deviation[row]:.3g} s off the least-squares uniform base t = {_g(fit.start)} s + k * "
        f"{_g(fit.period)} s, "
        f"farther than {_tolerance_text(fit, row, resolution)}; {off} of {time.size} stamps lie beyond "
        f"their tolerance (a sampling clock that drifts, or stamps out of line)"
    )


def _note(fit: UniformFit, resolution: Resolution | None) -> str:
    """One line: how far the stamps strayed, which tolerance covered it, and the base the record now uses."""
    worst = fit.worst
    rounding = fit.limits.rounding
    resolved = (
        resolution is not None
        and rounding is not None
        and all(
            bool(np.all(np.abs(fit.deviation(lo, hi)) <= np.maximum(rounding.at(lo, hi), fit.noise)))
            for lo, hi in _spans(fit.time.size)
        )
    )
    if resolved:
        why = f"within their resolution ({resolution.format}; {_g(resolution.step[-1])} s at the last stamp)"
    elif worst <= TIME_JITTER * fit.period:
        why = f"within the sampling jitter of {TIME_JITTER:g} of the period"
    else:
        last = float(np.spacing(np.float32(abs(fit.last()))))
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
    if fit is None or fit.worst <= max(TIME_JITTER * fit.period, fit.noise):
        return time, None
    return fit.times(), _note(fit, None)
