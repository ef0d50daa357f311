"""The loop's report: `report.json`, PNG plots (residual vs each added effect's features, force-velocity and
force-displacement loops before/after, PSD of the residual before/after) and `report.html` linking them."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

import nnfmu
from nnfmu.atomic import write_text_atomic
from nnfmu.data import Measurement
from nnfmu.data.units import base_name
from nnfmu.models.features import FeatureSpec
from nnfmu.reports.html import write_html
from nnfmu.validate import welch_psd
from nnfmu.validate.plots import axis_label, new_axes, psd_unit
from nnfmu.workflows.loop.results import LoopReport

TEMPLATE = "loop.html.j2"
LOOP_WINDOW = 2.0  # s of the first test block drawn in the force-velocity and force-displacement loops
MAX_SCATTER = 4000  # points per residual scatter
LONG_NUMBER = re.compile(r"\d+\.\d{4,}(?:e[-+]?\d+)?")  # a fitted parameter printed in full in a feature's name


def short_feature_name(name: str) -> str:
    """A feature's name with its fitted parameters to 3 significant digits, so that it fits under a plot axis."""
    return LONG_NUMBER.sub(lambda number: f"{float(number.group()):.3g}", name)


def feature_unit(spec: FeatureSpec, name: str, units: dict[str, str]) -> str:
    """SI unit of one feature column: the channel's for taps and low-pass states, 1 for a smoothed sign, the
    channel's squared for a running mean square."""
    for d in spec.derived:
        if d.name == name:
            unit = units.get(d.channel, "")
            if d.kind == "smooth_sign":
                return "1"
            if d.kind == "lowpass_square":
                return f"{unit}^2" if unit.isalnum() else f"({unit})^2"
            return unit
    channel = name.split("[", 1)[0]
    return units.get(channel, "")


def plot_residual_vs_features(
    report: LoopReport,
    m: Measurement,
    rows: np.ndarray,
    residual: np.ndarray,
    spec: FeatureSpec,
    names: tuple[str, ...],
    path: Path,
    effect: str,
) -> Path:
    """Residual before the effect was added against each feature the effect added (diagnosis part)."""
    values = spec.features({c: m[c] for c in spec.channels}, m.sample_period)
    figure = Figure(figsize=(max(7.0, 4.0 * len(names)), 4.0), dpi=100, layout="constrained")
    FigureCanvasAgg(figure)
    pick = rows[:: max(1, len(rows) // MAX_SCATTER)]
    unit = m.units.get(report.output, "")
    for i, name in enumerate(names):
        axes = figure.add_subplot(1, len(names), i + 1)
        axes.plot(values[pick, spec.feature_names.index(name)], residual[pick], ".", markersize=2, alpha=0.5)
        axes.xaxis.set_major_locator(MaxNLocator(4))  # a panel holds four labels like -0.0005 side by side
        axes.set_xlabel(axis_label(short_feature_name(name), feature_unit(spec, name, m.units)), parse_math=False)
        axes.set_ylabel(axis_label(f"residual {report.output}", unit), parse_math=False)
        axes.grid(True, alpha=0.3)
    figure.suptitle(f"residual before {effect} was added vs its features (diagnosis part)")
    figure.savefig(path, format="png")
    return path


def plot_loops(
    report: LoopReport,
    m: Measurement,
    rows: np.ndarray,
    before: np.ndarray,
    after: np.ndarray,
    x_channel: str,
    path: Path,
) -> Path:
    """Output over `x_channel` (velocity or displacement): measured, first model, final model, first test window."""
    window = rows[: int(round(LOOP_WINDOW / m.sample_period))]
    figure, axes = new_axes(
        f"{report.output} vs {x_channel}, test part {m.time[window[0]]:.3g} s to {m.time[window[-1]]:.3g} s"
    )
    x = m[x_channel][window]
    axes.plot(x, m[report.output][window], color="black", linewidth=1.0, label="measured")
    axes.plot(x, before[window], color="tab:blue", linewidth=1.0, label="before")
    axes.plot(x, after[window], color="tab:red", linewidth=1.0, label="after")
    axes.set_xlabel(axis_label(x_channel, m.units.get(x_channel, "")), parse_math=False)
    axes.set_ylabel(axis_label(report.output, m.units.get(report.output, "")), parse_math=False)
    axes.legend()
    figure.savefig(path, format="png")
    return path


def plot_residual_psd(
    report: LoopReport,
    m: Measurement,
    test_ranges: tuple[tuple[int, int], ...],
    before: np.ndarray,
    after: np.ndarray,
    path: Path,
) -> Path:
    """Welch PSD of the residual before and after, averaged over the test blocks."""
    unit = m.units.get(report.output, "")
    figure, axes = new_axes(f"PSD of the {report.output} residual on the test part")
    measured = np.asarray(m[report.output], dtype=float)
    for predicted, style in (
        (before, {"color": "tab:blue", "label": "before"}),
        (after, {"color": "tab:red", "label": "after"}),
    ):
        spectra = [welch_psd(measured[a:b] - predicted[a:b], m.sample_period) for a, b in test_ranges]
        size = min(len(s.frequency) for s in spectra)
        density = np.mean([s.density[:size] for s in spectra], axis=0)
        axes.semilogy(spectra[0].frequency[:size], density, linewidth=1.0, **style)
    axes.set_xlabel("frequency [Hz]")
    axes.set_ylabel(f"PSD [{psd_unit(unit)}]", parse_math=False)
    axes.legend()
    figure.savefig(path, format="png")
    return path


def write_loop_report(
    folder: Path,
    report: LoopReport,
    m: Measurement,
    rows: dict[str, np.ndarray],
    first: np.ndarray,
    final: np.ndarray,
    steps: list[tuple[np.ndarray, FeatureSpec]],
) -> None:
    """Plots, report.json and report.html into `folder` (the run's staging folder, renamed into place later).

    `first`/`final`: the first and the final model's output over the record; `steps`: per iteration, the output of
    the model before it and the extended feature spec."""
    plots: dict[str, str] = {}
    measured = np.asarray(m[report.output], dtype=float)
    for it, (previous, spec) in zip(report.iterations, steps):
        name = f"residual_vs_{it.effect}.png"
        plot_residual_vs_features(
            report, m, rows["diagnosis"], measured - previous, spec, it.features_added, folder / name, it.effect
        )
        plots[f"residual vs {it.effect}"] = name
    prefix = report.output[: len(report.output) - len(base_name(report.output) or "")]
    for quantity in ("velocity", "displacement"):
        channel = prefix + quantity
        if channel in m:
            name = f"{report.output}_vs_{quantity}.png"
            plot_loops(report, m, rows["test"], first, final, channel, folder / name)
            plots[f"{report.output}-{quantity} loop before/after"] = name
    ranges = tuple(_test_ranges(rows["test"]))
    plot_residual_psd(report, m, ranges, first, final, folder / "residual_psd.png")
    plots["residual PSD before/after"] = "residual_psd.png"
    document = {**report.to_dict(), "nnfmu_version": nnfmu.__version__, "plots": plots}
    write_text_atomic(folder / "report.json", json.dumps(document, indent=1, allow_nan=False))
    write_html(folder / "report.html", TEMPLATE, (document["summary"],), report=document)


def _test_ranges(test_rows: np.ndarray) -> list[tuple[int, int]]:
    """Contiguous (start, stop) runs of the test rows."""
    breaks = np.nonzero(np.diff(test_rows) != 1)[0]
    starts = np.concatenate([[0], breaks + 1])
    stops = np.concatenate([breaks + 1, [len(test_rows)]])
    return [(int(test_rows[a]), int(test_rows[b - 1]) + 1) for a, b in zip(starts, stops)]
