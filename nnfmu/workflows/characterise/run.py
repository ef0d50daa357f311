"""`nnfmu characterise`: a damper's or bushing's standard tests run on the model through its FMU at default
parameters, and on a measurement when given, written as CSV tables and an HTML report with the deviation per test
point. Everything is written into a staging folder beside `--out`, which replaces it only when complete."""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from nnfmu.atomic import staging_dir
from nnfmu.component import Component
from nnfmu.data import load_measurement
from nnfmu.data.measurement import Measurement
from nnfmu.export.band import carried_band
from nnfmu.export.own_error import OwnError, carried_own_errors
from nnfmu.out_paths import check_output_dir, replace_output_dir
from nnfmu.workflows.characterise.analysis import StiffnessPoint
from nnfmu.workflows.characterise.bushing import channel_plan, characterise_bushing
from nnfmu.workflows.characterise.damper import characterise_damper, command_levels, damper_tests
from nnfmu.workflows.characterise.envelope import INSIDE, envelope_note
from nnfmu.workflows.characterise.kind import BushingChannelPorts, BushingPorts, DamperPorts
from nnfmu.workflows.characterise.measured import Cycle, measured_bushing, measured_damper
from nnfmu.workflows.characterise.model import ModelUnderTest, model_under_test
from nnfmu.workflows.characterise.plots import characteristic_plot, loop_plot, stiffness_plots, work_diagram_plots
from nnfmu.workflows.characterise.report import INDEX_FILE, Section, write_report
from nnfmu.workflows.characterise.settings import VEHICLE_RANGE, CharacteriseSettings
from nnfmu.workflows.characterise.tables import (
    WITHIN,
    Row,
    characteristic_rows,
    gas_friction_rows,
    largest_deviation,
    loop_rows,
    model_cycles,
    stiffness_rows,
    work_diagram_rows,
)

KIND = "characterise"  # the output folder's marker
Log = Callable[[str], None]


@dataclass(frozen=True)
class CharacteriseReport:
    """What a run wrote: the component kind, the report's index.html, the headline rows for the terminal, and, beside
    a measurement when the network carries its own error, how many test points inside its training envelope are
    within that error (within, of)."""

    kind: str
    index: Path
    lines: list[str]
    within_own_error: tuple[int, int] | None = None


def _largest(rows: list[Row], columns: tuple[str, ...], where: tuple[str, ...]) -> list[str]:
    """The headline of a table with a measurement beside: each deviation column's largest value and where it was
    read; nothing without a measurement."""
    found = [text for column in columns if (text := largest_deviation(rows, column, where)) is not None]
    return [f"Largest deviation per column: {'; '.join(found)}."] if found else []


def _envelope_line(rows: list[Row], component: Component) -> list[str]:
    """How many test points drive the network beyond its training envelope or above its band (its answer there is
    extrapolation), and the band each input's training record excited when the network carries it."""
    outside = sum(row["training_envelope"] != INSIDE for row in rows)
    if not outside:
        lines = ["Every test point lies inside the network's training envelope and band (column training envelope)."]
    else:
        lines = [
            f"{outside} of {len(rows)} test points drive an input beyond the network's training envelope, or run "
            "above the frequency band its training record excited (column training envelope): its answer there is "
            "extrapolation, not what its rig data held."
        ]
    band = carried_band(component)
    if band:
        edges = ", ".join(f"{name} {edge:.3g} Hz" for name, edge in band.items())
        lines.append(f"Training band (99 % of each input's power below it in the training record): {edges}.")
    return lines


def _own_error_lines(rows: list[Row], own: list[OwnError], measured: bool) -> tuple[list[str], tuple[int, int] | None]:
    """Beside a measurement: the network's own error and how many test points are within it, inside its training
    envelope and outside (the count inside returned too); a loud line when the network carries none."""
    if not measured:
        return [], None
    if not own:
        return [
            "The network carries no own error (a graph from another tool or an older nnfmu): the deviations are not "
            "judged against it."
        ], None
    inside = [row for row in rows if row["training_envelope"] == INSIDE]
    outside = [row for row in rows if row["training_envelope"] != INSIDE]
    judged = [
        (sum(row.get(WITHIN) == "yes" for row in part), sum(WITHIN in row for row in part))
        for part in (inside, outside)
    ]
    counts = f"{judged[0][0]} of {judged[0][1]} test points inside the training envelope" + (
        f", {judged[1][0]} of {judged[1][1]} outside it" if judged[1][1] else ""
    )
    return [
        "Own error (the network's RMS error on the held-out test split of its training record, measurement noise "
        f"included): {'; '.join(o.text() for o in own)}. Within it (every deviation of a point at most the own "
        f"error; column {WITHIN}): {counts}."
    ], judged[0]


Outcome = tuple[list[Section], list[str], list[str], tuple[int, int] | None]  # sections, notes, lines, within


def _damper(
    model: ModelUnderTest,
    ports: DamperPorts,
    record: Measurement | None,
    settings: CharacteriseSettings,
    folder: Path,
    carried: dict[str, OwnError],
) -> Outcome:
    s = settings.damper
    command, unit = ports.command, ports.command_unit
    label = f"{command} [{unit}]" if command else None
    measured = measured_damper(record, ports, s.settle_cycles) if record is not None else None
    tests = (
        measured.tests if measured else damper_tests(s, command_levels(s, ports, model.component, str(model.source)))
    )
    result = characterise_damper(model, tests, s.temperature)
    cycles = model_cycles(result)
    own = carried.get("force")
    rows = characteristic_rows(result, label, measured, own)
    rates = {"velocity": "peak_velocity [m/s]", "displacement": "amplitude [m]"}
    for row in rows:
        peaks = {k: float(row[c] or 0.0) for k, c in rates.items()}
        row["training_envelope"] = envelope_note(model.component, peaks, float(row["frequency [Hz]"]))
    own_lines, within = _own_error_lines(rows, [own] if own else [], measured is not None)
    how = (
        f"sine tests found in {record.source}, run on the model at their amplitude, frequency and command"
        if measured and record is not None
        else f"sine of ±{s.stroke:g} m stroke amplitude per peak velocity"
    )
    main = Section(
        "Characteristic diagram",
        [
            f"Force at peak rebound velocity (positive) and at peak jounce velocity (negative) per test: {how}; "
            f"{s.settle_cycles} cycle(s) settling (the first ramped in), then the read cycle."
            + (" Deviation = model − measured." if measured else ""),
            *_largest(
                rows,
                (
                    "rebound_deviation [N]",
                    "rebound_deviation_relative [%]",
                    "jounce_deviation [N]",
                    "jounce_deviation_relative [%]",
                ),
                (label, "peak_velocity [m/s]") if label else ("peak_velocity [m/s]",),
            ),
            *own_lines,
            *_envelope_line(rows, model.component),
        ],
        [
            characteristic_plot(
                result.points, measured.points if measured else None, command, unit, folder / "characteristic.png"
            )
        ]
        if settings.figures
        else [],
        {"characteristic.csv": rows},
    )
    gas = Section(
        "Gas force and friction",
        [
            "Read from each command level's slowest test: the force of the samples moving at 20-60 % of its peak "
            "speed, fitted per direction by a line in velocity plus a term in displacement, meets zero speed at "
            "friction − gas force (rebound) and −friction − gas force (jounce)."
        ],
        tables={"gas_friction.csv": gas_friction_rows(result.gas_friction, label, measured)},
    )
    work = Section(
        "Work diagrams",
        [
            "Force against displacement and velocity over each test's read cycle"
            + (" (measured: the record's last full cycle of that test, dashed)." if measured else ".")
        ],
    )
    tables = {"work_diagrams.csv": work_diagram_rows(result.points, cycles, label)}
    if measured:
        tables["measured_work_diagrams.csv"] = work_diagram_rows(measured.points, measured.cycles, label, "measured_")
    work.tables = tables
    for i, level in enumerate(dict.fromkeys(p.command for p in result.points) if settings.figures else ()):
        idx = [j for j, p in enumerate(result.points) if p.command == level]
        title = "model" if level is None else f"{command} {level:.3g} {unit}"
        names = work_diagram_plots(
            [result.points[j] for j in idx],
            [cycles[j] for j in idx],
            [measured.cycles[j] for j in idx] if measured else None,
            title,
            folder / f"work_{i:02d}",
        )
        work.images.extend(names.values())
    notes = [f"skipped in the record: {why}" for why in measured.skipped] if measured else []
    lines = [
        f"{p.peak_velocity:6.3f} m/s: rebound {p.rebound_force:9.1f} N, jounce {p.jounce_force:9.1f} N"
        + (f" (command {p.command:.3g} {unit})" if p.command is not None else "")
        for p in result.points
    ]
    return [main, gas, work], notes, lines, within


def stiffness_line(channel: BushingChannelPorts, point: StiffnessPoint) -> str:
    """One dynamic-stiffness point for the terminal, every number with its unit, within 78 columns for nnfmu's
    channels (indented by 2 on an 80-column terminal): `conical_rotation 5 Hz, 0.04 rad: |K*| 1.234e+04 N.m/rad, loss
    12.3 deg` (loss: the loss angle)."""
    return (
        f"{point.channel} {point.frequency:.3g} Hz, {point.amplitude:.3g} {channel.position_unit}: |K*| "
        f"{point.dynamic_stiffness:.4g} {channel.stiffness_unit}, loss {point.loss_angle:.3g} deg"
    )


def _bushing(
    model: ModelUnderTest,
    ports: BushingPorts,
    record: Measurement | None,
    settings: CharacteriseSettings,
    folder: Path,
    carried: dict[str, OwnError],
) -> Outcome:
    s = settings.bushing
    measured = measured_bushing(record, ports, s.settle_cycles) if record is not None else None
    plans = [channel_plan(ch, s) for ch in ports.channels]
    if measured:
        plans = [type(p)(p.channel, measured.tests[p.channel.key], measured.loops[p.channel.key][0]) for p in plans]
    result = characterise_bushing(model, plans)
    ranges = ", ".join(f"{ch.key} {VEHICLE_RANGE[ch.key]:g} {ch.position_unit}" for ch in ports.channels)
    how = (
        f"the sine tests found in {record.source}, run on the model at their amplitude and frequency"
        if measured and record is not None
        else f"every frequency at amplitudes {', '.join(f'{a:g}' for a in s.amplitude_fractions)} of the channel's "
        f"vehicle range ({ranges})"
    )
    rows = stiffness_rows(result.channels, result.points, measured, carried)
    points = [(ch, p) for ch in result.channels for p in result.points[ch.key]]  # the rows' order
    for row, (ch, p) in zip(rows, points, strict=True):
        peaks = {ch.position: p.amplitude} | ({ch.rate: 2 * math.pi * p.frequency * p.amplitude} if ch.rate else {})
        row["training_envelope"] = envelope_note(model.component, peaks, p.frequency)
    own = [carried[ch.force] for ch in result.channels if ch.force in carried]
    own_lines, within = _own_error_lines(rows, own, measured is not None)
    stiffness = Section(
        "Dynamic stiffness and loss angle",
        [
            f"Per channel (the others at rest): {how}; {s.settle_cycles} cycle(s) settling, then the read "
            "cycle. |K*| and the loss angle are the modulus and angle of K*, the ratio of the first-harmonic "
            "phasors of force and deflection (least squares on sin and cos)."
            + (" Deviation = model − measured." if measured else ""),
            *_largest(
                rows,
                ("stiffness_deviation [%]", "loss_angle_deviation [deg]"),
                ("channel", "frequency [Hz]", "amplitude [m]", "amplitude [rad]"),
            ),
            *own_lines,
            *_envelope_line(rows, model.component),
        ],
        tables={"dynamic_stiffness.csv": rows},
    )
    loop = Section(
        "Quasi-static force-deflection loop",
        [
            (
                "The model at the record's slowest test, beside the record's last cycle of it (dashed)."
                if measured
                else f"A sine at {s.quasi_static_frequency:g} Hz at the largest amplitude, after one settling cycle."
            )
        ],
        tables={"quasi_static_loop.csv": loop_rows(result, measured)},
    )
    for ch in result.channels if settings.figures else ():
        stiffness.images.extend(
            stiffness_plots(
                ch, result.points[ch.key], measured.points[ch.key] if measured else None, folder / ch.key
            ).values()
        )
        run = result.loops[ch.key]
        _t, x, v, f = run.cycle()
        title = f"force-deflection loop at {run.test.frequency:.3g} Hz"
        loop.images.append(
            loop_plot(
                ch,
                Cycle(x, v, f),
                measured.loops[ch.key][1] if measured else None,
                title,
                folder / f"{ch.key}_loop.png",
            )
        )
    lines = [stiffness_line(ch, p) for ch in result.channels for p in result.points[ch.key]]
    return [stiffness, loop], [], lines, within


def characterise(
    model_path: str | os.PathLike[str],
    out: str | os.PathLike[str],
    measured: str | os.PathLike[str] | Measurement | None = None,
    settings: CharacteriseSettings | None = None,
    log: Log = print,
) -> CharacteriseReport:
    """Run the standard tests of the model at `model_path` (`.onnx` or `.fmu`) and of the record `measured` (a file,
    or one already loaded), and write the report into `out` (module docstring)."""
    settings = settings or CharacteriseSettings()
    loaded = isinstance(measured, Measurement)
    inputs = [Path(model_path)] + ([Path(measured.source if loaded else measured)] if measured is not None else [])
    out_dir = check_output_dir(out, KIND, inputs, replaces=True)
    record = measured if loaded or measured is None else load_measurement(measured)
    with model_under_test(model_path) as model:
        kind = model.kind.kind
        log(f"{model.source}: {kind}, tested through {model.fmu.name} at {model.period:g} s")
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        with staging_dir(out_dir.parent, f".{out_dir.name}.staging-") as staging:
            own = carried_own_errors(model.component)
            if isinstance(model.kind, DamperPorts):
                sections, notes, lines, within = _damper(model, model.kind, record, settings, staging, own)
            else:
                sections, notes, lines, within = _bushing(model, model.kind, record, settings, staging, own)
            context = {
                "model": str(model.source),
                "component": model.component.name,
                "kind": kind
                + (f" (semi-active, {model.kind.command})" if getattr(model.kind, "command", None) else ""),
                "tested through": f"its FMU at default parameters, sample period {model.period:g} s",
                "measurement": str(record.source) if record is not None else "none",
                "own error (held-out test split)": "; ".join(o.text() for o in own.values())
                or "not carried (a graph from another tool or an older nnfmu)",
            }
            if not settings.figures:
                notes.append("figures: not drawn (a quick run); the tables hold every test point")
            write_report(staging, f"{kind} characterisation of {model.component.name}", context, notes, sections)
            replace_output_dir(staging, out_dir, KIND)
    if within is not None:
        lines.append(f"within the network's own error: {within[0]} of {within[1]} test points inside its envelope")
    return CharacteriseReport(kind, out_dir / INDEX_FILE, lines, within)
