"""The report's tables as rows (column `name [unit]` -> value), written as CSV and shown in the HTML report: the model's
values, the measurement's beside them as `measured_*` columns, and the deviation (model − measured) per test point,
over the network's own error where it carries one."""

from __future__ import annotations

import cmath
import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path

from nnfmu.export.own_error import OwnError
from nnfmu.workflows.characterise.analysis import DamperPoint, GasAndFriction, StiffnessPoint
from nnfmu.workflows.characterise.bushing import BushingResult
from nnfmu.workflows.characterise.damper import DamperResult
from nnfmu.workflows.characterise.kind import BushingChannelPorts
from nnfmu.workflows.characterise.measured import Cycle, MeasuredBushing, MeasuredDamper

Row = dict[str, float | str | None]


def _relative(model: float, measured: float) -> float | None:
    """(model − measured) / |measured| in per cent; None where the measured value is zero."""
    return None if measured == 0 else 100.0 * (model - measured) / abs(measured)


def _command(label: str | None, level: float | None) -> Row:
    return {label: level} if label else {}


WITHIN = "within_own_error"


def _over_own(deviation: float, own: OwnError | None) -> Row:
    """A test point's largest |deviation| over the network's own RMS error, and whether it is within it (`yes`/`no`);
    nothing when the network carries no own error."""
    if own is None:
        return {}
    ratio = abs(deviation) / own.rms_error if own.rms_error > 0 else None
    return {"deviation_over_own_error [1]": ratio, WITHIN: "yes" if abs(deviation) <= own.rms_error else "no"}


def characteristic_rows(
    result: DamperResult, command: str | None, measured: MeasuredDamper | None = None, own: OwnError | None = None
) -> list[Row]:
    """`characteristic.csv`: per test point the peak velocity, stroke, frequency, rebound force (positive) and
    jounce force (negative); with a measurement its values and the deviations beside them, the larger over the
    network's own error `own` when it carries one."""
    rows = []
    for i, p in enumerate(result.points):
        row = {
            **_command(command, p.command),
            "peak_velocity [m/s]": p.peak_velocity,
            "amplitude [m]": p.amplitude,
            "frequency [Hz]": p.frequency,
            "rebound_force [N]": p.rebound_force,
            "jounce_force [N]": p.jounce_force,
        }
        if measured is not None:
            m: DamperPoint = measured.points[i]
            rebound, jounce = p.rebound_force - m.rebound_force, p.jounce_force - m.jounce_force
            row.update(
                {
                    "measured_peak_velocity [m/s]": m.peak_velocity,
                    "measured_rebound_force [N]": m.rebound_force,
                    "measured_jounce_force [N]": m.jounce_force,
                    "rebound_deviation [N]": rebound,
                    "jounce_deviation [N]": jounce,
                    "rebound_deviation_relative [%]": _relative(p.rebound_force, m.rebound_force),
                    "jounce_deviation_relative [%]": _relative(p.jounce_force, m.jounce_force),
                }
                | _over_own(max(abs(rebound), abs(jounce)), own)
            )
        rows.append(row)
    return rows


def gas_friction_rows(
    found: dict[float | None, GasAndFriction], command: str | None, measured: MeasuredDamper | None = None
) -> list[Row]:
    """`gas_friction.csv`: per command level the gas force and friction read from its slowest test."""
    rows = []
    for level, g in found.items():
        row = {
            **_command(command, level),
            "peak_velocity [m/s]": g.peak_velocity,
            "gas_force [N]": g.gas_force,
            "friction [N]": g.friction,
        }
        if measured is not None and level in measured.gas_friction:
            m = measured.gas_friction[level]
            row.update(
                {
                    "measured_peak_velocity [m/s]": m.peak_velocity,
                    "measured_gas_force [N]": m.gas_force,
                    "measured_friction [N]": m.friction,
                    "gas_force_deviation [N]": g.gas_force - m.gas_force,
                    "friction_deviation [N]": g.friction - m.friction,
                }
            )
        rows.append(row)
    return rows


def work_diagram_rows(
    points: Sequence[DamperPoint], cycles: Sequence[Cycle], command: str | None, prefix: str = ""
) -> list[Row]:
    """`work_diagrams.csv` (or the measured one): every sample of each test's cycle, labelled by its test."""
    rows = []
    for p, c in zip(points, cycles):
        for x, v, f in zip(c.position, c.rate, c.force):
            rows.append(
                {
                    **_command(command, p.command),
                    "test_peak_velocity [m/s]": p.peak_velocity,
                    f"{prefix}displacement [m]": float(x),
                    f"{prefix}velocity [m/s]": float(v),
                    f"{prefix}force [N]": float(f),
                }
            )
    return rows


def model_cycles(result: DamperResult) -> list[Cycle]:
    """The measured cycle of each of the model's runs."""
    return [Cycle(*run.cycle()[1:]) for run in result.runs]


def harmonic_force_deviation(model: StiffnessPoint, measured: StiffnessPoint) -> float:
    """The first-harmonic force the model gets wrong at a measured point, as an RMS (in the force's unit, beside the
    network's own RMS error): |K*model − K*measured| times the measured amplitude over √2."""
    k_model = cmath.rect(model.dynamic_stiffness, math.radians(model.loss_angle))
    k_measured = cmath.rect(measured.dynamic_stiffness, math.radians(measured.loss_angle))
    return abs(k_model - k_measured) * measured.amplitude / math.sqrt(2.0)


def stiffness_rows(
    channels: Sequence[BushingChannelPorts],
    points: dict[str, list[StiffnessPoint]],
    measured: MeasuredBushing | None = None,
    own: dict[str, OwnError] | None = None,
) -> list[Row]:
    """`dynamic_stiffness.csv`: per channel, frequency and amplitude |K*| and the loss angle; amplitude and
    stiffness columns per unit (m and N/m, rad and N.m/rad), empty where a row's channel has the other unit; with a
    measurement the first-harmonic force deviation, over the channel's own error `own[force output]` when carried."""
    rows = []
    for ch in channels:
        for i, p in enumerate(points[ch.key]):
            row = {
                "channel": ch.key,
                "frequency [Hz]": p.frequency,
                f"amplitude [{ch.position_unit}]": p.amplitude,
                f"dynamic_stiffness [{ch.stiffness_unit}]": p.dynamic_stiffness,
                "loss_angle [deg]": p.loss_angle,
            }
            if measured is not None:
                m = measured.points[ch.key][i]
                deviation = harmonic_force_deviation(p, m)
                row.update(
                    {
                        f"measured_dynamic_stiffness [{ch.stiffness_unit}]": m.dynamic_stiffness,
                        "measured_loss_angle [deg]": m.loss_angle,
                        "stiffness_deviation [%]": _relative(p.dynamic_stiffness, m.dynamic_stiffness),
                        "loss_angle_deviation [deg]": p.loss_angle - m.loss_angle,
                        f"harmonic_force_deviation_rms [{ch.force_unit}]": deviation,
                    }
                    | _over_own(deviation, (own or {}).get(ch.force))
                )
            rows.append(row)
    return rows


def loop_rows(result: BushingResult, measured: MeasuredBushing | None = None) -> list[Row]:
    """`quasi_static_loop.csv`: each channel's position and force over its loop cycle, side by side (the measured
    cycle's beside); shorter columns end empty."""
    columns: dict[str, list[float]] = {}
    for ch in result.channels:
        _t, x, _v, f = result.loops[ch.key].cycle()
        columns[f"{ch.position} [{ch.position_unit}]"] = list(x)
        columns[f"{ch.force} [{ch.force_unit}]"] = list(f)
        if measured is not None:
            cycle = measured.loops[ch.key][1]
            columns[f"measured_{ch.position} [{ch.position_unit}]"] = list(cycle.position)
            columns[f"measured_{ch.force} [{ch.force_unit}]"] = list(cycle.force)
    length = max(len(v) for v in columns.values())
    return [{name: (values[i] if i < len(values) else None) for name, values in columns.items()} for i in range(length)]


def _cell(value: float | str | None) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    return value if isinstance(value, str) else f"{float(value):.12g}"


def csv_text(rows: Sequence[Row]) -> str:
    """The rows as CSV, columns in first-seen order, missing cells empty."""
    header: dict[str, None] = {}
    for row in rows:
        header.update(dict.fromkeys(row))
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([_cell(row.get(name)) for name in header])
    return buffer.getvalue()


def write_csv(path: Path, rows: Sequence[Row]) -> Path:
    """Write `rows` to `path` (inside a staging folder: the result is moved into place as a whole)."""
    path.write_text(csv_text(rows), encoding="utf-8")
    return path


def _finite(row: Row, column: str) -> float | None:
    value = row.get(column)
    return float(value) if isinstance(value, float) and math.isfinite(value) else None


def largest_deviation(rows: Sequence[Row], column: str, where: Sequence[str]) -> str | None:
    """The report's headline of one deviation column: its value of largest magnitude (with unit) and the test point
    it was read at (`where`: the columns naming it, `name [unit]` or text); None when no row has one."""
    found = [(abs(v), r, v) for r in rows if (v := _finite(r, column)) is not None]
    if not found:
        return None
    _, row, value = max(found, key=lambda f: f[0])
    parts = []
    for w in where:
        number = _finite(row, w)
        if number is not None:
            parts.append(f"{number:.3g} {w.partition(' [')[2].rstrip(']')}")
        elif isinstance(row.get(w), str):
            parts.append(str(row[w]))
    name, _, unit = column.partition(" [")
    return f"{name.replace('_', ' ')} {value:+.3g} {unit.rstrip(']')} at {', '.join(parts)}"
