"""The iteration's record: report.json (per iteration and channel NRMSE, RMS ratio [dB], global RMS error,
pseudo-damage ratio; convergence; coherence of the FRF) and a self-contained report.html (figures inline)."""

from __future__ import annotations

import io
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from nnfmu.data import Measurement
from nnfmu.reports.html import inline_png, write_html
from nnfmu.validate.spectra import welch_psd
from nnfmu.workflows.iterate.loop import RMS_ALARM_DB, Outcome
from nnfmu.workflows.iterate.settings import IterateSettings

MAX_POINTS = 4000  # points per time-history line in the HTML report
DEFINITIONS = {
    "nrmse": "RMS(response - target) / RMS(target) over the whole record, means included [1]",
    "rms_ratio_db": f"20 log10(RMS(response) / RMS(target)) [dB]; the lab's alarm at ±{RMS_ALARM_DB:g} dB",
    "global_rms_error": (
        "MIL-STD-810H Method 525.2's global RMS error as nnfmu computes it: RMS of the difference over the whole "
        "record relative to the target's RMS [1] (numerically the NRMSE)"
    ),
    "pseudo_damage_ratio": "D(response) / D(target), rainflow cycles and Basquin slope (nnfmu.validate.damage) [1]",
    "coherence": "multiple coherence of each response with all actuator drives per FRF line (H1 estimate) [1]",
    "step_taken": "fraction of the iteration's correction applied (< 1 where a full step would exceed a limit) [1]",
    "limit_use": "the drive's peak stroke, velocity and acceleration as fractions of the actuator limits [1]",
}


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def report_dict(
    outcome: Outcome,
    channels: Sequence[str],
    actuators: Sequence[str],
    settings: IterateSettings,
    target: Measurement,
    system: Path,
) -> dict[str, object]:
    """The JSON report (NaN and infinities as null)."""
    frf = outcome.frf_noise
    inside = (frf.frequency >= settings.band[0]) & (frf.frequency <= settings.band[1])
    return {
        "target": str(target.source),
        "system": str(system),
        "channels": list(channels),
        "actuators": list(actuators),
        "converged": outcome.converged,
        "best_iteration": outcome.iterations[outcome.best].index,
        "seconds": round(outcome.seconds, 3),
        "settings": {
            "iterations": settings.iterations,
            "gain": settings.gain,
            "band_hz": list(settings.band),
            "tolerance": {c: settings.tolerance_of(c) for c in channels},
            "noise_level_m_per_s": settings.noise_level,
            "noise_duration_s": settings.noise_duration,
            "noise_scale": outcome.noise_scale,
            "resolution_hz": settings.resolution,
            "regularisation": settings.regularisation,
            "reestimate": settings.reestimate,
            "fade_s": settings.fade,
            "step_s": settings.step,
            "basquin_slope": settings.basquin_slope,
            "limits": {
                "stroke_m": settings.limits.stroke,
                "velocity_m_per_s": settings.limits.velocity,
                "acceleration_m_per_s2": settings.limits.acceleration,
            },
        },
        "iterations": [
            {
                "iteration": it.index,
                "step_taken": it.step_taken,
                "frf_reestimated": it.frf_reestimated,
                "limit_use": it.limit_use,
                "channels": {c: {k: _finite(v) for k, v in m.items()} for c, m in it.metrics.items()},
                "rms_alarm": [c for c, m in it.metrics.items() if abs(m["rms_ratio_db"]) > RMS_ALARM_DB],
            }
            for it in outcome.iterations
        ],
        "coherence": {
            "frequency_hz": [float(f) for f in frf.frequency[inside]],
            "mean_in_band": {c: float(np.mean(frf.coherence[inside, i])) for i, c in enumerate(channels)},
            "min_in_band": {c: float(np.min(frf.coherence[inside, i])) for i, c in enumerate(channels)},
            "channels": {c: [round(float(g), 5) for g in frf.coherence[inside, i]] for i, c in enumerate(channels)},
        },
        "notes": list(outcome.notes),
        "definitions": DEFINITIONS,
    }


def _figure(height: float = 3.2) -> tuple[Figure, object]:
    figure = Figure(figsize=(9.0, height), dpi=90, layout="tight")
    FigureCanvasAgg(figure)
    return figure, figure.add_subplot()


def _inline(figure: Figure) -> str:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return inline_png(buffer.getvalue())


def _figures(
    outcome: Outcome, target: np.ndarray, dt: float, channels: Sequence[str], units: dict[str, str]
) -> list[tuple[str, str]]:
    """(title, inline PNG address) per figure: the error per iteration, each channel's target and response with
    their PSDs, the identification's coherence."""
    best = outcome.iterations[outcome.best]
    parts = []
    figure, axes = _figure()
    for name in channels:
        axes.semilogy(
            [it.index for it in outcome.iterations],
            [it.metrics[name]["nrmse"] for it in outcome.iterations],
            marker="o",
            label=name,
        )
    axes.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes.set_xlabel("iteration [1]")
    axes.set_ylabel("NRMSE [1]")
    axes.set_title("error per iteration", parse_math=False)
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=8)
    parts.append(("Error per iteration", _inline(figure)))
    t = np.arange(target.shape[0]) * dt
    every = max(1, target.shape[0] // MAX_POINTS)  # lines of at most MAX_POINTS points (the PSDs use every sample)
    for i, name in enumerate(channels):
        unit = units.get(name, "") or "1"
        figure = Figure(figsize=(9.0, 5.4), dpi=90, layout="tight")
        FigureCanvasAgg(figure)
        top, bottom = figure.subplots(2, 1)
        top.plot(t[::every], target[::every, i], color="black", linewidth=0.6, label="target")
        top.plot(t[::every], best.response[::every, i], color="tab:red", linewidth=0.6, label=f"iteration {best.index}")
        top.set_xlabel("time [s]")
        top.set_ylabel(f"{name} [{unit}]", parse_math=False)
        top.legend(fontsize=8)
        for signal, style in ((target[:, i], "black"), (best.response[:, i], "tab:red")):
            psd = welch_psd(signal, dt, fmax=min(0.5 / dt, 100.0), resolution=0.25)
            bottom.semilogy(psd.frequency, psd.density, color=style, linewidth=0.8)
        bottom.set_xlabel("frequency [Hz]")
        bottom.set_ylabel(f"PSD [({unit})^2/Hz]", parse_math=False)
        parts.append((f"{name}: target and response, PSDs", _inline(figure)))
    figure, axes = _figure()
    frf = outcome.frf_noise
    for i, name in enumerate(channels):
        axes.plot(frf.frequency, frf.coherence[:, i], linewidth=0.8, label=name)
    axes.set_xlabel("frequency [Hz]")
    axes.set_ylabel("multiple coherence [1]")
    axes.set_ylim(0, 1.05)
    axes.legend(fontsize=8)
    parts.append(("Coherence of the identification", _inline(figure)))
    return parts


def write_report(
    folder: Path,
    outcome: Outcome,
    target: np.ndarray,
    dt: float,
    channels: Sequence[str],
    actuators: Sequence[str],
    settings: IterateSettings,
    record: Measurement,
    system: Path,
) -> None:
    """report.json and the self-contained report.html into `folder` (a staging folder)."""
    report = report_dict(outcome, channels, actuators, settings, record, system)
    (folder / "report.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    write_html(
        folder / "report.html",
        "iterate.html.j2",
        status="converged" if outcome.converged else "not converged",
        source=str(record.source),
        system=str(system),
        report=report,
        channels=list(channels),
        figures=_figures(outcome, target, dt, channels, dict(record.units)),
    )
