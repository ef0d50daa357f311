"""The campaign's HTML summary: the programme damage ratio per channel and variant, the worst events, the failures.

The programme damage of a variant on a channel is the sum of its pseudo-damage over the events (Miner's rule adds
damage), taken over the events where both it and the reference ran; its ratio to the reference's sum is what the
durability engineer reads. The worst events of a channel are the event x variant cases with the highest damage ratio
against the reference on that event. Plots are PNGs beside `summary.html` (matplotlib, Agg), written atomically.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from nnfmu.atomic import atomic_path
from nnfmu.reports.html import write_html
from nnfmu.workflows.campaign.execute import FAILED, OK

TEMPLATE = "campaign.html.j2"
SUMMARY = "summary.html"
RATIO_PLOT = "damage_ratio.png"
WORST_PLOT = "worst_events.png"
WORST_COUNT = 8  # cases shown per channel among the worst events


@dataclass(frozen=True)
class Worst:
    """One case among a channel's worst: its event, variant and damage ratio against the reference."""

    event: str
    variant: str
    ratio: float


@dataclass(frozen=True)
class Digest:
    """What the summary shows, computed from the results table."""

    channels: list[tuple[str, str]]  # (channel, unit), in table order
    variants: list[str]
    reference: str
    programme: dict[str, dict[str, float]]  # channel -> variant -> programme damage ratio
    worst: dict[str, list[Worst]]  # channel -> worst cases, highest ratio first
    failures: list[dict[str, Any]]  # one per failed case: event, variant, error


def digest(table: pa.Table, reference: str) -> Digest:
    """Programme damage ratios, worst events and failures of a results table."""
    rows = table.to_pylist()
    channels = list(dict.fromkeys((r["channel"], r["unit"]) for r in rows if r["status"] == OK))
    variants = list(dict.fromkeys(r["variant"] for r in rows))
    ok = {(r["event"], r["variant"], r["channel"]): r for r in rows if r["status"] == OK}
    programme: dict[str, dict[str, float]] = defaultdict(dict)
    worst: dict[str, list[Worst]] = {}
    for channel, _ in channels:
        for variant in variants:
            pairs = [
                (row["damage"], ok[(e, reference, c)]["damage"])
                for (e, v, c), row in ok.items()
                if v == variant and c == channel and (e, reference, c) in ok
            ]
            total = sum(b for _, b in pairs)
            programme[channel][variant] = sum(a for a, _ in pairs) / total if total > 0 else float("nan")
        cases = [
            Worst(e, v, row["damage_ratio"])
            for (e, v, c), row in ok.items()
            if c == channel and v != reference and np.isfinite(row["damage_ratio"])
        ]
        worst[channel] = sorted(cases, key=lambda w: -w.ratio)[:WORST_COUNT]
    failures = list(
        {
            (r["event"], r["variant"]): {"event": r["event"], "variant": r["variant"], "error": r["error"]}
            for r in rows
            if r["status"] == FAILED
        }.values()
    )
    return Digest(channels, variants, reference, dict(programme), worst, failures)


def verdict(d: Digest) -> str:
    """The summary's one line: the largest programme damage ratio of any variant against the campaign's reference
    variant (what a campaign is run for: does a variant load a channel more than the reference?)."""
    ratios = [
        (ratio, variant, channel, unit)
        for channel, unit in d.channels
        for variant, ratio in d.programme[channel].items()
        if variant != d.reference and np.isfinite(ratio)
    ]
    if not ratios:
        return f"no variant besides the reference {d.reference} has a damage ratio to judge"
    ratio, variant, channel, unit = max(ratios)
    change = "more" if ratio > 1 else "less"
    return (
        f"worst: {variant} on {channel} [{unit}], programme damage ratio {ratio:.3g} — {abs(ratio - 1):.0%} {change} "
        f"damage than the reference variant {d.reference} (the campaign's reference, ratio 1)"
    )


def _plain(text: str) -> str:
    """`text` for a tick or legend label, shown as it is (a `$` would start matplotlib's math text there)."""
    return text.replace("$", r"\$")


def _figure(width: float, height: float) -> Figure:
    figure = Figure(figsize=(width, height), dpi=100, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _save(figure: Figure, path: Path) -> None:
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png")


def plot_programme(d: Digest, path: Path) -> None:
    """Grouped bars: programme damage ratio [1] per channel (x, with its unit) and variant (bars), 1 = reference."""
    figure = _figure(max(6.0, 1.4 * len(d.channels) * max(1, len(d.variants)) / 3 + 3), 4.5)
    axes = figure.add_subplot()
    width = 0.8 / max(1, len(d.variants))
    x = np.arange(len(d.channels))
    for i, variant in enumerate(d.variants):
        values = [d.programme[c][variant] for c, _ in d.channels]
        axes.bar(x + (i - (len(d.variants) - 1) / 2) * width, values, width, label=_plain(variant))
    axes.axhline(1.0, color="black", linewidth=0.8)
    axes.set_xticks(x, [_plain(f"{c} [{u}]") for c, u in d.channels], rotation=20, ha="right")
    axes.set_ylabel(f"programme pseudo-damage ratio vs {d.reference} [1]", parse_math=False)
    axes.set_xlabel("channel [unit]")
    axes.set_title("damage ratio per channel and variant (sum over events)", parse_math=False)
    axes.grid(True, axis="y", alpha=0.3)
    axes.legend(fontsize="small")
    _save(figure, path)


def plot_worst(d: Digest, path: Path) -> None:
    """One panel per channel: the cases with the highest damage ratio [1] against the reference on their event."""
    shown = [(c, u) for c, u in d.channels if d.worst.get(c)]
    figure = _figure(8.0, max(2.5, sum(1.0 + 0.28 * len(d.worst[c]) for c, _ in shown)))
    if not shown:
        axes = figure.add_subplot()
        axes.text(0.5, 0.5, "no case besides the reference ran", ha="center", va="center")
        axes.set_axis_off()
    for i, (channel, unit) in enumerate(shown):
        axes = figure.add_subplot(len(shown), 1, i + 1) if len(shown) > 1 else figure.add_subplot()
        cases = d.worst[channel][::-1]
        axes.barh(np.arange(len(cases)), [w.ratio for w in cases], color="tab:red")
        axes.set_yticks(np.arange(len(cases)), [_plain(f"{w.event} / {w.variant}") for w in cases], fontsize="small")
        axes.axvline(1.0, color="black", linewidth=0.8)
        axes.set_xlabel(f"pseudo-damage ratio vs {d.reference} [1]", parse_math=False)
        axes.set_title(f"worst events: {channel} [{unit}]", parse_math=False)
        axes.grid(True, axis="x", alpha=0.3)
    _save(figure, path)


def write_summary(out: Path, table: pa.Table, reference: str, context: dict[str, Any]) -> Path:
    """`out/summary.html` with its two plots; `context` adds the campaign's name, counts and engine."""
    d = digest(table, reference)
    plot_programme(d, out / RATIO_PLOT)
    plot_worst(d, out / WORST_PLOT)
    return write_html(
        out / SUMMARY, TEMPLATE, (verdict(d),), d=d, ratio_plot=RATIO_PLOT, worst_plot=WORST_PLOT, **context
    )
