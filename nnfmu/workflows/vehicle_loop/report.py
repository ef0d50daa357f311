"""The vehicle loop's report: what it found and did (`VehicleLoopReport`), written as `report.json`, a
time-history plot per channel the named effects explain most (lab car, virtual car before and after) and the NRMSE of
every channel before and after, and `report.html` linking them."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

import nnfmu
from nnfmu.atomic import write_text_atomic
from nnfmu.data import Measurement
from nnfmu.reports.html import write_html
from nnfmu.validate.plots import axis_label, new_axes

if TYPE_CHECKING:
    from nnfmu.diagnosis import Diagnosis
    from nnfmu.workflows.vehicle_loop.attribution import Attribution
    from nnfmu.workflows.vehicle_loop.fix import Fixed
    from nnfmu.workflows.vehicle_loop.residuals import ChannelError

TEMPLATE = "vehicle_loop.html.j2"
WINDOW = 3.0  # [s] of the record drawn in a time-history plot, from its settled start


@dataclass
class VehicleLoopReport:
    """What the vehicle loop found and did (JSON-ready by `to_dict`)."""

    measured: str
    system: str
    fixed_system: Path
    fmus: dict[str, Path]
    channels: dict[str, dict[str, ChannelError]]
    attribution: Attribution
    fixes: list[Fixed]
    offsets: dict[str, float]
    in_situ: dict[str, Diagnosis]
    coverage: list[str]
    ignored: list[str]
    summary: str
    notes: list[str] = field(default_factory=list)
    untested: list[str] = field(default_factory=list)

    @property
    def iterations(self) -> list[dict[str, object]]:
        """The named (component, effect) pairs and sensor offsets, in the order named."""
        out = []
        for e in self.attribution.named:
            situ = self.in_situ.get(e.candidate.component)
            words = (
                f"explains {e.explained:.1%} of the vehicle residual beyond those named before (alone "
                f"{e.explained_alone:.1%}), out of sample; most in "
                + ", ".join(f"{c} ({v:.0%})" for c, v in sorted(e.channels.items(), key=lambda kv: -kv[1])[:3])
            )
            if situ is not None:
                words += f"; in situ: {situ.summary}"
            if e.alike:
                words += f"; cannot be told apart from {', '.join(e.alike)} by these channels"
            out.append(
                {
                    "component": e.candidate.component,
                    "effect": e.candidate.effect,
                    "evidence": words,
                    "why": e.why,
                    "p_value": e.p_value,
                }
            )
        return out

    def to_dict(self) -> dict[str, object]:
        return {
            "measured": self.measured,
            "system_before": self.system,
            "system": str(self.fixed_system),
            "fmus": {k: str(v) for k, v in self.fmus.items()},
            "summary": self.summary,
            "iterations": self.iterations,
            "channels": {
                name: {when: error.to_dict() for when, error in pair.items()} for name, pair in self.channels.items()
            },
            "channels_note": (
                "virtual car vs lab car after the settling time; mean_shift = mean(virtual) - mean(measured) in the "
                "channel's unit; 'after' compares the fixed system with the record, sensor offsets taken out of "
                "their channels"
            ),
            "sensor_offsets": self.offsets,
            "fixes": [
                {"component": f.element, "method": f.method, "fmu": str(f.fmu), "onnx": str(f.onnx)} for f in self.fixes
            ],
            "candidates": [e.to_dict() for e in self.attribution.evidence],
            "significance_threshold": self.attribution.threshold,
            "untestable": self.attribution.untestable,
            "untested_components": self.untested,
            "in_situ": {k: d.to_dict() for k, d in self.in_situ.items()},
            "coverage": self.coverage,
            "ignored_channels": self.ignored,
            "notes": self.notes,
        }


def plot_channel(
    name: str, measured: Measurement, before: Measurement, after: Measurement, corrected: Measurement, path: Path
) -> Path:
    """One channel over the first WINDOW seconds: lab car (as recorded and offset-corrected), virtual before/after."""
    rows = measured.time <= measured.time[0] + WINDOW
    figure, axes = new_axes(f"{name}: lab car vs virtual car")
    t = measured.time[rows]
    axes.plot(t, measured[name][rows], color="black", linewidth=1.0, label="lab car")
    if not np.array_equal(corrected[name], measured[name]):
        axes.plot(t, corrected[name][rows], color="grey", linewidth=1.0, label="lab car, offset removed")
    axes.plot(t, before[name][rows], color="tab:blue", linewidth=1.0, label="virtual before")
    axes.plot(t, after[name][rows], color="tab:red", linewidth=1.0, label="virtual after")
    axes.set_xlabel("time [s]")
    axes.set_ylabel(axis_label(name, measured.units.get(name, "")), parse_math=False)
    axes.legend()
    figure.savefig(path, format="png")
    return path


def plot_nrmse(report: VehicleLoopReport, path: Path) -> Path:
    """NRMSE [%] of every channel before and after, bars side by side."""
    names = list(report.channels)
    figure, axes = new_axes("NRMSE per channel, virtual vs lab car", height=max(4.0, 0.3 * len(names)))
    y = np.arange(len(names))
    for shift, when, color in ((-0.2, "before", "tab:blue"), (0.2, "after", "tab:red")):
        values = [100 * report.channels[n][when].nrmse for n in names]
        axes.barh(y + shift, values, height=0.4, color=color, label=when)
    axes.set_yticks(y, names)
    axes.set_xscale("log")
    # 1-2-5 ticks as plain numbers: within a decade the default labels every minor tick and they collide
    axes.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axes.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    axes.xaxis.set_minor_formatter(NullFormatter())
    axes.set_xlabel("NRMSE [%]")
    axes.legend()
    figure.savefig(path, format="png")
    return path


def write_vehicle_report(
    folder: Path,
    report: VehicleLoopReport,
    measured: Measurement,
    before: Measurement,
    after: Measurement,
    corrected: Measurement,
) -> None:
    """Plots, report.json and report.html into `folder` (the run's staging folder, renamed into place later)."""
    plots = {"NRMSE before/after": plot_nrmse(report, folder / "nrmse.png").name}
    shown: list[str] = []
    for e in report.attribution.named:
        shown += [c for c, _ in sorted(e.channels.items(), key=lambda kv: -kv[1])[:2] if c not in shown]
    for name in shown or list(report.channels)[:2]:
        plots[f"{name} before/after"] = plot_channel(
            name, measured, before, after, corrected, folder / f"{name}.png"
        ).name
    document = {**report.to_dict(), "nnfmu_version": nnfmu.__version__, "plots": plots}
    write_text_atomic(folder / "report.json", json.dumps(document, indent=1, allow_nan=False))
    write_html(folder / "report.html", TEMPLATE, (document["summary"],), report=document)
