"""The thesis's comparison of a co-simulated channel with its reference, as one row of numbers per channel and model.

The thesis compared the hysteresis network with the spline baseline by force peaks, the amplitude at 1 Hz and mean
shifts at 0 Hz; durability engineers add RMS and rainflow pseudo-damage. All come from one `ChannelComparison`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from nnfmu.validate import ChannelComparison
from nnfmu.validate.meaningful import frequency_reason
from nnfmu.validate.summary import json_float
from nnfmu.validate.verdict import Target, verdict

AMPLITUDE_FREQUENCY = 1.0  # [Hz] where the thesis read its amplitude ratio


@dataclass(frozen=True)
class ThesisRow:
    """One channel of one model against the reference; ratios [1], mean shift in the channel's unit; `not_meaningful`:
    column -> why the record is too short for it (the value is then NaN, null in JSON)."""

    channel: str
    unit: str
    model: str
    peak_ratio: float
    valley_ratio: float
    rms_ratio: float
    damage_ratio: float
    amplitude_ratio_1hz: float
    mean_shift: float
    nrmse: float
    not_meaningful: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, object]:
        return {k: (json_float(v) if isinstance(v, float) else v) for k, v in asdict(self).items()}


def amplitude_ratio(c: ChannelComparison, frequency: float = AMPLITUDE_FREQUENCY) -> float:
    """sqrt(PSD_result / PSD_reference) at `frequency` [Hz] (linear between PSD lines): the amplitude ratio there;
    NaN (not meaningful) when the record is too short for it (`nnfmu.validate.meaningful.frequency_reason`: a 0.3 s
    record's first line lies at 3.3 Hz) or the reference has no power there."""
    if _amplitude_reason(c, frequency) is not None:
        return float("nan")
    result = float(np.interp(frequency, c.psd_result.frequency, c.psd_result.density))
    reference = float(np.interp(frequency, c.psd_reference.frequency, c.psd_reference.density))
    return float(np.sqrt(result / reference)) if reference > 0 else float("nan")


def _amplitude_reason(c: ChannelComparison, frequency: float) -> str | None:
    return frequency_reason(float(c.time[-1] - c.time[0]), c.psd_reference.frequency, frequency)


def thesis_row(c: ChannelComparison, model: str) -> ThesisRow:
    """The thesis comparison of channel `c` for `model`."""
    m = c.metrics
    reasons = {"amplitude_ratio_1hz": _amplitude_reason(c, AMPLITUDE_FREQUENCY)}
    if "pseudo_damage_ratio" in m.not_meaningful:
        reasons["damage_ratio"] = m.not_meaningful["pseudo_damage_ratio"]
    return ThesisRow(
        channel=c.name,
        unit=c.unit,
        model=model,
        peak_ratio=m.peak_ratio,
        valley_ratio=m.valley_ratio,
        rms_ratio=m.rms_ratio,
        damage_ratio=m.pseudo_damage_ratio,
        amplitude_ratio_1hz=amplitude_ratio(c),
        mean_shift=m.mean_shift,
        nrmse=m.nrmse,
        not_meaningful={k: v for k, v in reasons.items() if v is not None},
    )


def model_verdicts(rows: list[ThesisRow], target: Target) -> list[str]:
    """One line per model (in table order): its worst channel's NRMSE against the monolithic reference, judged
    against `target`."""
    models = list(dict.fromkeys(r.model for r in rows))
    lines = []
    for model in models:
        own = [r for r in rows if r.model == model]
        worst = max(own, key=lambda r: r.nrmse if np.isfinite(r.nrmse) else -1.0)
        which = "worst channel " if len(own) > 1 else ""
        lines.append(verdict(f"{model}: {which}{worst.channel} [{worst.unit}]", worst.nrmse, target))
    return lines
