"""The terminal tables of `nnfmu train` and `nnfmu demo`, laid out to fit 80 columns: short headers, errors in per
cent as the documentation gives them, a legend line for what the short headers mean."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

from rich import box
from rich.table import Table
from rich.text import Text

from nnfmu.workflows.progress import clock_time

# Rows of `metrics_table`: (key of SplitMetrics.as_dict, label, scale, format); NRMSE is shown in per cent.
METRIC_ROWS = (
    ("nrmse", "NRMSE [%]", 100.0, "{:.2f}"),
    ("r2", "R²", 1.0, "{:.4f}"),
    ("peak_error", "max |error| [SI]", 1.0, "{:.4g}"),
    ("slope", "slope", 1.0, "{:.4f}"),
    ("intercept", "intercept [SI]", 1.0, "{:.4g}"),
    ("mse_scaled", "MSE (scaled)", 1.0, "{:.3g}"),
    ("max_abs_weight", "largest |weight|", 1.0, "{:.3g}"),
    ("samples", "samples", 1.0, "{:.0f}"),
)
COMPONENT_LEGEND = (
    "train: training time [s]; test: NRMSE on the lab record's test split; FMU: NRMSE of the FMU replayed on the "
    "held-out random record; peak: peak error; damage: pseudo-damage ratio (FMU / measured)"
)


class ModelRow(Protocol):
    preset: str
    train_seconds: float
    test_split_nrmse: float
    replay_nrmse: float
    replay_r2: float
    replay_peak_error: float
    replay_pseudo_damage_ratio: float


def _per_cent(value: float) -> str:
    return "—" if value != value else f"{100 * value:.2f}"  # NaN: no number


def metrics_table(metrics: Mapping[str, Mapping[str, float]]) -> Table:
    """A metric per row, a split (train, validation, test) per column."""
    table = Table(box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False, collapse_padding=True)
    table.add_column("metric")
    for split in metrics:
        table.add_column(split, justify="right")
    for key, label, scale, form in METRIC_ROWS:
        table.add_row(label, *(form.format(scale * values[key]) for values in metrics.values()))
    return table


def component_table(models: Sequence[ModelRow]) -> Table:
    """The demo's component FMUs on their held-out records, one per row."""
    table = Table(
        title="component FMUs on held-out random rig records",
        box=box.SIMPLE_HEAD,
        show_edge=False,
        pad_edge=False,
        collapse_padding=True,
    )
    for column in ("preset", "train [s]", "test [%]", "FMU [%]", "R²", "peak [%]", "damage"):
        table.add_column(Text(column), justify="left" if column == "preset" else "right", no_wrap=True)
    for m in models:
        table.add_row(
            m.preset,
            f"{m.train_seconds:.1f}",
            _per_cent(m.test_split_nrmse),
            _per_cent(m.replay_nrmse),
            f"{m.replay_r2:.4f}",
            f"{100 * m.replay_peak_error:+.1f}",
            f"{m.replay_pseudo_damage_ratio:.3f}",
        )
    return table


def loop_table(effects: Sequence[str], before: Mapping[str, float | None], after: Mapping[str, float | None]) -> Table:
    """The loop's held-out error before and after the effects it added."""
    table = Table(
        title=f"effects added: {', '.join(effects) or 'none'}",
        box=box.SIMPLE_HEAD,
        show_edge=False,
        pad_edge=False,
        collapse_padding=True,
    )
    for column in ("held-out error", "before", "after"):
        table.add_column(Text(column), justify="left" if column == "held-out error" else "right")
    table.add_row("NRMSE [%]", _per_cent(before["nrmse"]), _per_cent(after["nrmse"]))
    table.add_row("R²", f"{before['r2']:.4f}", f"{after['r2']:.4f}")
    table.add_row("peak error [%]", f"{100 * before['peak_error']:+.1f}", f"{100 * after['peak_error']:+.1f}")
    table.add_row("pseudo-damage ratio", _ratio(before["pseudo_damage_ratio"]), _ratio(after["pseudo_damage_ratio"]))
    return table


def _ratio(value: float | None) -> str:
    """A ratio to three decimals, or why there is none (a record too short for it)."""
    return "not meaningful" if value is None else f"{value:.3f}"


def stage_table(seconds: Mapping[str, float], total: float) -> Table:
    """Each stage's wall time and the whole run's."""
    table = Table(title="time per stage", box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False, collapse_padding=True)
    table.add_column("stage")
    table.add_column("time", justify="right")
    for stage, spent in seconds.items():
        table.add_row(stage, clock_time(spent))
    table.add_row("total", clock_time(total), style="bold")
    return table
