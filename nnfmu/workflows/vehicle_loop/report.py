"""The vehicle loop's report: `report.json`, a time-history plot per channel the named effects explain most (lab
car, virtual car before and after) and the NRMSE of every channel before and after, and `report.html` linking them."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import jinja2
import numpy as np

import nnfmu
from nnfmu.atomic import write_text_atomic
from nnfmu.data import Measurement
from nnfmu.diagnosis.evidence import p_value_text
from nnfmu.validate.plots import axis_label, new_axes
from nnfmu.validate.verdict import per_cent

if TYPE_CHECKING:
    from nnfmu.workflows.vehicle_loop.run import VehicleLoopReport

TEMPLATE = "vehicle_report.html.j2"
WINDOW = 3.0  # [s] of the record drawn in a time-history plot, from its settled start


def _number(value: object) -> str:
    if isinstance(value, (int, float)):
        return f"{value:.4g}"
    return "–" if value is None else str(value)


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
    environment = jinja2.Environment(
        loader=jinja2.PackageLoader("nnfmu.workflows.vehicle_loop", "."),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
    )
    environment.filters["number"] = _number
    environment.filters["per_cent"] = per_cent
    environment.filters["p_value"] = p_value_text
    write_text_atomic(folder / "report.html", environment.get_template(TEMPLATE).render(report=document))
