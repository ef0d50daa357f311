"""The report's PNG figures, drawn with the validation floor's helpers (off-screen Agg axes, `name [unit]` labels):
the model as solid lines, the measurement as markers or dashed lines of the same colour."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from matplotlib.ticker import FormatStrFormatter, NullFormatter

from nnfmu.validate.plots import axis_label, new_axes
from nnfmu.workflows.characterise.analysis import DamperPoint, StiffnessPoint
from nnfmu.workflows.characterise.kind import BushingChannelPorts
from nnfmu.workflows.characterise.measured import Cycle


def _save(figure, path: Path) -> str:  # noqa: ANN001 (matplotlib Figure)
    figure.savefig(path, format="png")
    return path.name


def _levels(points: Sequence[DamperPoint]) -> list:
    return list(dict.fromkeys(p.command for p in points))


def _level_label(level: float | None, command: str | None, unit: str) -> str:
    return "" if level is None else f"{command} {level:.3g} {unit}: "


def amplitude_groups(amplitudes: Sequence[float], tolerance: float = 0.02) -> list[int]:
    """A group number per amplitude: amplitudes within `tolerance` (relative) of a group's first share it, so the
    tests a record holds at one nominal amplitude form one line."""
    firsts: list[float] = []
    groups = []
    for a in amplitudes:
        found = next((i for i, f in enumerate(firsts) if abs(a - f) <= tolerance * max(abs(a), abs(f))), None)
        if found is None:
            firsts.append(a)
            found = len(firsts) - 1
        groups.append(found)
    return groups


def characteristic_plot(
    points: Sequence[DamperPoint],
    measured: Sequence[DamperPoint] | None,
    command: str | None,
    unit: str,
    path: Path,
) -> str:
    """Rebound and jounce force against peak velocity, a line per command level, measured points as circles."""
    figure, axes = new_axes("damper characteristic: force at peak velocity")
    for i, level in enumerate(_levels(points)):
        chosen = [p for p in points if p.command == level]
        v = [p.peak_velocity for p in chosen]
        label = _level_label(level, command, unit)
        axes.plot(v, [p.rebound_force for p in chosen], "-s", color=f"C{i}", label=f"{label}rebound")
        axes.plot(v, [p.jounce_force for p in chosen], "--v", color=f"C{i}", label=f"{label}jounce")
        if measured is not None:
            mine = [m for m, p in zip(measured, points) if p.command == level]
            mv = [m.peak_velocity for m in mine]
            axes.plot(mv, [m.rebound_force for m in mine], "o", mfc="none", color=f"C{i}", label=f"{label}measured")
            axes.plot(mv, [m.jounce_force for m in mine], "o", mfc="none", color=f"C{i}")
    axes.axhline(0.0, color="black", linewidth=0.5)
    axes.set_xlabel("peak velocity [m/s]")
    axes.set_ylabel("force [N] (rebound +, jounce −)")
    axes.legend(fontsize="small")
    return _save(figure, path)


def work_diagram_plots(
    points: Sequence[DamperPoint],
    cycles: Sequence[Cycle],
    measured: Sequence[Cycle] | None,
    title: str,
    stem: Path,
) -> dict[str, str]:
    """Force against displacement and against velocity, a colour per test speed; measured cycles dashed."""
    names = {}
    for key, xlabel in (("displacement", "displacement [m]"), ("velocity", "velocity [m/s]")):
        figure, axes = new_axes(f"{title}: force-{key} work diagram")
        for i, (p, c) in enumerate(zip(points, cycles)):
            x = c.position if key == "displacement" else c.rate
            axes.plot(x, c.force, color=f"C{i % 10}", linewidth=1.0, label=f"{p.peak_velocity:.3g} m/s")
            if measured is not None:
                m = measured[i]
                axes.plot(m.position if key == "displacement" else m.rate, m.force, "--", color=f"C{i % 10}", lw=0.8)
        axes.set_xlabel(xlabel)
        axes.set_ylabel("force [N]")
        axes.legend(fontsize="small", title="model (measured dashed)" if measured is not None else None)
        names[key] = _save(figure, stem.with_name(f"{stem.name}_{key}.png"))
    return names


# A stiffness plot's frequency axis spans at least this factor either side of its tests (a record at one frequency, an
# amplitude sweep, would otherwise get an axis of zero width), and its value axis at least this share of its largest
# value (a model whose |K*| does not change with amplitude).
FREQUENCY_MARGIN = 1.25
MIN_VALUE_SPAN = 0.01


def _widened(axes, frequencies: Sequence[float], values: Sequence[float]) -> None:  # noqa: ANN001 (matplotlib Axes)
    """Axis limits that hold every point with room around it, however close the points lie together."""
    axes.set_xlim(min(frequencies) / FREQUENCY_MARGIN, max(frequencies) * FREQUENCY_MARGIN)
    low, high = axes.get_ylim()
    need = MIN_VALUE_SPAN * max(abs(v) for v in values) or 1.0
    if high - low < need:
        centre = (min(values) + max(values)) / 2
        axes.set_ylim(centre - need / 2, centre + need / 2)


def stiffness_plots(
    channel: BushingChannelPorts,
    points: Sequence[StiffnessPoint],
    measured: Sequence[StiffnessPoint] | None,
    stem: Path,
) -> dict[str, str]:
    """|K*| and loss angle against frequency (log axis), a line per amplitude; measured points as circles."""
    groups = amplitude_groups([p.amplitude for p in points])
    # one tick per test frequency to 3 digits: a record's tests run at its measured frequencies (14.99, 15.02 Hz)
    frequencies = sorted({float(f"{p.frequency:.3g}") for p in points})
    names = {}
    for key, label in (("dynamic_stiffness", f"|K*| [{channel.stiffness_unit}]"), ("loss_angle", "loss angle [deg]")):
        figure, axes = new_axes(f"{channel.key}: {'dynamic stiffness' if key == 'dynamic_stiffness' else 'loss angle'}")
        for group in sorted(set(groups)):
            idx = sorted((j for j, g in enumerate(groups) if g == group), key=lambda j: points[j].frequency)
            f = [points[j].frequency for j in idx]
            amplitude = sum(points[j].amplitude for j in idx) / len(idx)
            text = f"{amplitude:.3g} {channel.position_unit}"
            axes.plot(f, [getattr(points[j], key) for j in idx], "-s", color=f"C{group % 10}", label=text)
            if measured is not None:
                axes.plot(f, [getattr(measured[j], key) for j in idx], "o", mfc="none", color=f"C{group % 10}")
        axes.set_xscale("log")
        shown = [getattr(q, key) for q in [*points, *(measured or [])]]
        _widened(axes, [q.frequency for q in points], shown)
        axes.set_xticks(frequencies)
        axes.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        axes.xaxis.set_minor_formatter(NullFormatter())
        axes.set_xlabel("frequency [Hz]")
        axes.set_ylabel(label)
        axes.legend(fontsize="small", title="amplitude (measured: circles)" if measured is not None else "amplitude")
        names[key] = _save(figure, stem.with_name(f"{stem.name}_{key}.png"))
    return names


def loop_plot(channel: BushingChannelPorts, model: Cycle, measured: Cycle | None, title: str, path: Path) -> str:
    """The quasi-static force-deflection loop, the measured one dashed."""
    figure, axes = new_axes(f"{channel.key}: {title}")
    axes.plot(model.position, model.force, color="tab:red", linewidth=1.0, label="model")
    if measured is not None:
        axes.plot(measured.position, measured.force, "--", color="black", linewidth=1.0, label="measured")
    axes.set_xlabel(axis_label(channel.position, channel.position_unit), parse_math=False)
    axes.set_ylabel(axis_label(channel.force, channel.force_unit), parse_math=False)
    axes.legend()
    return _save(figure, path)
