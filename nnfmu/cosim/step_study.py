"""Step study: the same co-simulation at h, h/2 and h/4, and per output channel the coupling error of the run at h
estimated by step halving (Richardson), so a user learns whether the step is small enough without a reference.

With y_h, y_h2, y_h4 the three runs on the common axis t_n = t0 + n h, d1 = y_h - y_h2 and d2 = y_h2 - y_h4, the
observed order is p = log2(rms d1 / rms d2) and the error of the run at h is e_h = d1 2^p / (2^p - 1) (the error
of y_h against the limit h -> 0 if the error behaves as C h^p). Its NRMSE is rms e_h / rms y_h4 (nnfmu's NRMSE:
RMS error over the RMS of the reference); the largest step meeting a target NRMSE follows from the same law,
h_max = h (target / NRMSE)^(1/p), with p clipped to [ORDER_RANGE] for that extrapolation. Where only two runs exist
(the master refused h/4) the order is taken as 1, the cautious choice; with one run nothing is estimated. A step
the master refuses is reported with its reason, never changed.

Mind elements that sample at a period T and hold their outputs (nnfmu's network FMUs): below T their outputs get no
finer, so the differences stop shrinking and the observed order falls; the study reports each element's T.
"""

from __future__ import annotations

import math
import textwrap
import time as clock
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from nnfmu.cosim.master import CosimError, CosimSettings
from nnfmu.cosim.results import CosimResult
from nnfmu.cosim.ssp import SystemStructure
from nnfmu.data import Measurement
from nnfmu.errors import NnfmuError

HALVINGS = 3  # runs at h, h/2, h/4
ORDER_RANGE = (0.5, 4.0)  # the observed order used to extrapolate the largest step is clipped to this
DEFAULT_TARGET = 0.01  # NRMSE a channel should meet (1 %)
WIDTH = 80  # characters per printed line
Runner = Callable[[CosimSettings], CosimResult]


@dataclass(frozen=True)
class ChannelEstimate:
    """One output channel: the estimated NRMSE of the run at h and at h/2 (fractions), the order p used (observed,
    or assumed when `observed` is False), and the largest step [s] meeting the target (inf: any step)."""

    name: str
    unit: str
    nrmse_h: float
    nrmse_h2: float
    order: float
    observed: bool
    max_step: float


@dataclass
class StepStudy:
    """The study's runs (step [s] -> wall time [s]), the steps the master refused (step -> its reason), the target
    NRMSE, the channels' estimates and the sample periods [s] of the elements that have one."""

    step: float
    target: float
    runs: dict[float, float] = field(default_factory=dict)
    refused: dict[float, str] = field(default_factory=dict)
    channels: list[ChannelEstimate] = field(default_factory=list)
    sample_periods: dict[str, float] = field(default_factory=dict)

    def largest_step(self) -> float | None:
        """The largest step meeting the target on every channel (None: nothing estimated)."""
        return min((c.max_step for c in self.channels), default=None)

    def as_dict(self) -> dict:
        return {
            "step_s": self.step,
            "target_nrmse": self.target,
            "runs_wall_time_s": {f"{h:.9g}": wall for h, wall in self.runs.items()},
            "refused": {f"{h:.9g}": why for h, why in self.refused.items()},
            "sample_periods_s": self.sample_periods,
            "largest_step_s": _number(self.largest_step()),
            "channels": {
                c.name: {
                    "unit": c.unit,
                    "nrmse_at_h": _number(c.nrmse_h),
                    "nrmse_at_h2": _number(c.nrmse_h2),
                    "order": _number(c.order),
                    "order_observed": c.observed,
                    "largest_step_s": _number(c.max_step),
                }
                for c in self.channels
            },
        }


def _number(value: float | None) -> float | str | None:
    """A JSON number, or 'inf' (JSON has no infinity)."""
    if value is None:
        return None
    return "inf" if math.isinf(value) else float(value)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def estimate(name: str, unit: str, runs: list[np.ndarray], h: float, target: float) -> ChannelEstimate:
    """The channel's estimate from its values at t_n = t0 + n h of two or three runs (h, h/2[, h/4])."""
    d1 = runs[0] - runs[1]
    reference = runs[-1]
    scale = _rms(reference)
    order, observed = 1.0, False
    if len(runs) > 2:
        r1, r2 = _rms(d1), _rms(runs[1] - runs[2])
        if r1 > 0 and r2 > 0 and r1 > r2:
            order, observed = math.log2(r1 / r2), True
    p = min(max(order, ORDER_RANGE[0]), ORDER_RANGE[1])
    error = _rms(d1) * 2**p / (2**p - 1)
    nrmse = error / scale if scale > 0 else (0.0 if error == 0 else math.inf)
    max_step = math.inf if nrmse == 0 else h * (target / nrmse) ** (1 / p)
    return ChannelEstimate(name, unit, nrmse, nrmse / 2**p, order, observed, max_step)


def sample_periods(system: SystemStructure) -> dict[str, float]:
    """Each element's annotated sample period T [s] (nnfmu's FMUs), by element; elements without one left out."""
    from nnfmu.fmu import fmu_sample_period

    periods = {}
    for element in system.elements:
        period = fmu_sample_period(system.fmu_path(element))
        if period is not None:
            periods[element.name] = period
    return periods


def study_step(
    system: SystemStructure, settings: CosimSettings, run: Runner, target: float = DEFAULT_TARGET
) -> StepStudy:
    """Run `run` at settings.step, its half and its quarter over the first run's span and estimate every channel."""
    if not (math.isfinite(target) and 0 < target < 1):
        raise CosimError(f"target NRMSE {target!r} must lie between 0 and 1 (0.01 is 1 %)")
    h = settings.step
    study = StepStudy(step=h, target=target, sample_periods=sample_periods(system))
    results: list[Measurement] = []
    for k in range(HALVINGS):
        step = h / 2**k
        started = clock.perf_counter()
        try:
            result = run(replace(settings, step=step, stop_time=stop_of(settings, results)))
        except NnfmuError as error:
            if k == 0:
                raise
            study.refused[step] = str(error)
            break
        study.runs[step] = round(clock.perf_counter() - started, 3)
        results.append(result.measurement)
    if len(results) < 2:
        return study
    n = len(results[0])
    for name in results[0].names:
        runs = [m[name][:: 2**k][:n] for k, m in enumerate(results)]
        study.channels.append(estimate(name, results[0].units[name], runs, h, target))
    return study


def stop_of(settings: CosimSettings, results: list[Measurement]) -> float | None:
    """The later runs end where the first ended, so the three share one span."""
    return float(results[0].time[-1]) if results else settings.stop_time


def _step_text(seconds: float) -> str:
    if math.isinf(seconds):
        return "any"
    return f"{seconds * 1e3:.3g} ms" if seconds < 1 else f"{seconds:.3g} s"


def _percent(fraction: float) -> str:
    return "inf" if math.isinf(fraction) else f"{100 * fraction:.2g} %"


def study_lines(study: StepStudy) -> list[str]:
    """The study as text lines of at most 80 characters: a table per channel, then what it means."""
    h = study.step
    lines = [
        f"step study: estimated coupling error (NRMSE) of the run at h = {_step_text(h)}, target "
        f"{_percent(study.target)}"
    ]
    if study.channels:
        header = f"{'channel':<28} {'unit':<7} {'at h':>8} {'at h/2':>8} {'order':>6}  {'step for target':>15}"
        lines += [header, "-" * len(header)]
        for c in study.channels:
            order = f"{c.order:.2g}" + ("" if c.observed else "*")
            name = c.name if len(c.name) <= 28 else c.name[:27] + "~"
            lines.append(
                f"{name:<28} {c.unit[:7]:<7} {_percent(c.nrmse_h):>8} {_percent(c.nrmse_h2):>8} {order:>6}  "
                f"{_step_text(c.max_step):>15}"
            )
        if any(not c.observed for c in study.channels):
            lines.append("* order not observed (two runs, or no decrease): taken as 1")
        missed = [c.name for c in study.channels if c.nrmse_h > study.target]
        largest = study.largest_step()
        lines.append(
            f"every channel meets {_percent(study.target)} at h"
            if not missed
            else f"{len(missed)} channel(s) miss {_percent(study.target)} at h: {', '.join(missed)}"
        )
        lines.append(f"largest step meeting it on every channel (extrapolated): {_step_text(largest)}")
    else:
        lines.append("no estimate: the master ran only the step h")
    for step, why in study.refused.items():
        lines.append(f"step {_step_text(step)} refused by the master: {why}")
    for name, period in study.sample_periods.items():
        if period > h / 4 * (1 + 1e-9):
            lines.append(
                f"note: {name} samples every {_step_text(period)} and holds its outputs between samples: below that "
                "step its outputs get no finer and the observed order falls"
            )
    return [wrapped for line in lines for wrapped in textwrap.wrap(line, WIDTH, subsequent_indent="  ")]
