"""`nnfmu loop vehicle`: the lab car on the road test simulator against the virtual car (the SSP system with its
network FMUs) on the same drive; per channel the residual; which component and which effect explain it
(`attribution`), or a sensor offset; the component fixed (`fix`), its FMU swapped into a copy of the system, the
system replayed; the report. Every file goes into a staging folder beside `out_dir`, which replaces `out_dir` only
when everything succeeded."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from nnfmu.atomic import scratch_dir, staging_dir
from nnfmu.data import DataError, Measurement, load_measurement
from nnfmu.data.drive_files import RPC_SUFFIXES, read_drive
from nnfmu.diagnosis import SYSTEM_EFFECTS
from nnfmu.fmu import FmuBuildError, load_onnx
from nnfmu.kinds import DAMPER
from nnfmu.out_paths import check_output_dir, replace_output_dir
from nnfmu.stopping import check_stop
from nnfmu.workflows.system import VirtualSystem
from nnfmu.workflows.vehicle_loop.attribution import (
    SENSOR_OFFSET,
    Candidate,
    Evidence,
    attribute,
    component_candidate,
    offset_candidate,
)
from nnfmu.workflows.vehicle_loop.fix import (
    Fixed,
    fix_by_terms,
    fix_in_situ,
    in_situ_diagnosis,
    in_situ_record,
    trained_network,
)
from nnfmu.workflows.vehicle_loop.report import VehicleLoopReport, write_vehicle_report
from nnfmu.workflows.vehicle_loop.residuals import ChannelError, channel_errors, on_record, replay_system, settled
from nnfmu.workflows.vehicle_loop.sensitivity import PERTURBATION, Sensitivities, network_stiffness
from nnfmu.workflows.vehicle_loop.settings import VehicleLoopError, VehicleLoopSettings
from nnfmu.workflows.vehicle_loop.system_files import VirtualCar, read_virtual_car

Log = Callable[[str], None]
MAX_ATTRIBUTION_BYTES = 2 * 1024**3  # the attribution's designs and their copies, checked before the sensitivities
ATTRIBUTION_COPIES = 4  # copies of a named candidate's columns held at once: the base, its held-out halves, a fit
BUDGET = (
    "consistent with the co-simulation error budget: no component effect or sensor offset explains a significant "
    "share of the residual, which is left to the networks' own error and the coupling"
)


def _load(data: str | os.PathLike[str] | Measurement, what: str, reader) -> Measurement:
    if isinstance(data, Measurement):
        return data
    try:
        return reader(data)
    except DataError as error:
        raise VehicleLoopError(f"cannot read the {what}: {error}") from None


def _corner_channels(corner: str) -> tuple[str, ...]:
    """The lab channels at one corner that a component there moves first."""
    return (
        f"lca_{corner}_angle",
        f"damper_{corner}_displacement",
        f"damper_{corner}_force",
        f"spindle_{corner}_acceleration",
        f"body_acceleration_{corner}",
    )


def _read_record(path: str | os.PathLike[str]) -> Measurement:
    """A lab record: an RPC III time history (what a road-test simulator's controller writes) or any file
    `load_measurement` reads (CSV, MDF, MTS 793 export)."""
    return read_drive(path) if Path(path).suffix.lower() in RPC_SUFFIXES else load_measurement(path)


def _coverage(car: VirtualCar, channels: list[str], retrainable: Mapping[str, bool]) -> list[str]:
    """What the measured channels allow and what a missing one costs, per component element (its kind's words in
    `_COVERAGE`)."""
    notes = []
    arms: dict[str, list[str]] = {}
    for element in car.fmus:
        kind = car.kind(element)
        words = _COVERAGE.get(kind.name) if kind is not None else None
        if car.onnx[element] is None:
            notes.append(f"{element}: {_untested_words(car, element)}")
        elif words is not None:
            notes.append(words(element, channels, retrainable[element], arms))
    for corner, elements in arms.items():
        if len(elements) > 1:
            notes.append(
                f"{' and '.join(elements)} hold the same arm: only how the arm's motion splits between their "
                "deflections tells their stiffnesses apart"
            )
    if not any(c.endswith("_force") and DAMPER.owns(c) for c in channels):
        notes.append(
            "no damper force measured: a damper's gas force and other spring-like effects at a corner are told "
            "apart only by their signatures in the motions and accelerations"
        )
    return notes


def _damper_coverage(element: str, channels: list[str], retrainable: bool, arms: dict[str, list[str]]) -> str:
    """What a damper's load cell and LVDT allow, measured or not."""
    force, stroke = f"{element}_force" in channels, f"{element}_displacement" in channels
    if force and stroke and retrainable:
        return f"{element}: load cell and LVDT measured: in-situ diagnosis and retraining"
    if force and stroke:
        return (
            f"{element}: load cell and LVDT measured, but its step graph is no network nnfmu trained: no "
            "in-situ diagnosis; its effects are fitted as physical terms to the vehicle residual"
        )
    lacking = [c for c, ok in ((f"{element}_force", force), (f"{element}_displacement", stroke)) if not ok]
    return (
        f"{element}: {', '.join(lacking)} not measured: no in-situ data, so its effects are fitted as "
        "physical terms to the vehicle residual"
        + (
            "; without its load cell a gas preload shows only as a shift of its corner's attitude, which "
            "a zero offset of that corner's LCA angle or LVDT also gives"
            if not force
            else ""
        )
    )


def _bushing_coverage(element: str, channels: list[str], retrainable: bool, arms: dict[str, list[str]]) -> str:
    """Where a bushing shows at its corner (no lab channel measures it); the element joins its corner's `arms`."""
    corner = element.split("_")[1] if element.count("_") >= 2 else ""
    arms.setdefault(corner, []).append(element)
    seen = [c for c in _corner_channels(corner) if c in channels]
    return (
        f"{element}: no lab channel measures its deflection or force, so its stiffness is fitted as physical "
        "terms to the vehicle residual, "
        + (
            f"seen at its corner through {', '.join(seen)}"
            if seen
            else f"and no channel at its corner ({', '.join(_corner_channels(corner))}) is measured: it "
            "shows only through the other corners, if at all"
        )
        + (
            ""
            if f"lca_{corner}_angle" in channels
            else f"; without lca_{corner}_angle its arm's rotation "
            "is read only from the damper stroke and the accelerations"
        )
    )


# The coverage words per component kind (a kind's name in `nnfmu.kinds`); a kind not here gets none.
_COVERAGE: dict[str, Callable[[str, list[str], bool, dict[str, list[str]]], str]] = {
    "damper": _damper_coverage,
    "bushing": _bushing_coverage,
}


def _candidates(
    car: VirtualCar, channels: list[str], replay: Measurement
) -> tuple[dict[str, Candidate], dict[str, str]]:
    """Every component element's candidate effects, the diagnosis registry's `SYSTEM_EFFECTS` its kind names (one
    scaled by stiffness: the network's own along the virtual car's `replay`), a sensor offset per measured channel;
    and the candidates that cannot be tested."""
    found: dict[str, Candidate] = {}
    untestable: dict[str, str] = {}
    for element in car.fmus:
        kind = car.kind(element)
        for name in kind.loop_effects if kind is not None else ():
            effect = SYSTEM_EFFECTS[name]
            stiffness = network_stiffness(replay, element, kind.channels) if effect.scaled_by_stiffness else {}
            c = component_candidate(element, effect, kind.channels, stiffness, PERTURBATION)
            if c is None:
                untestable[f"{element}:{name}"] = effect.untestable
            elif car.onnx[element] is None:
                untestable[c.key] = "no ONNX step graph of the element"
            else:
                found[c.key] = c
    for channel in channels:
        c = offset_candidate(channel)
        found[c.key] = c
    return found, untestable


def run_vehicle_loop(
    measured: str | os.PathLike[str] | Measurement,
    system: str | os.PathLike[str] | VirtualSystem,
    drive: str | os.PathLike[str] | Measurement,
    out_dir: str | os.PathLike[str],
    settings: VehicleLoopSettings = VehicleLoopSettings(),
    models: Mapping[str, str | Path] | None = None,
    log: Log = print,
) -> VehicleLoopReport:
    """Close the loop at vehicle level (module docstring); write DIR/report.json, report.html, plots, the fixed
    system (system/SystemStructure.ssd) and its FMUs. Each element's step graph is the one its FMU carries; `models`
    maps elements to ONNX step graphs that override them (`system_files.read_virtual_car`)."""
    with scratch_dir("nnfmu-step-graphs-") as graphs:
        return _run_vehicle_loop(measured, system, drive, out_dir, settings, models, log, Path(graphs))


def _untested_words(car: VirtualCar, element: str) -> str:
    """Why an element's effects are not tested and how to make them testable."""
    return (
        f"its effects are not tested: its FMU {car.fmus[element].name} carries no step graph and none was given; "
        f"rebuild the FMU with nnfmu build (it then carries its graph) or give --model {element}=ONNX"
    )


def _run_vehicle_loop(
    measured: str | os.PathLike[str] | Measurement,
    system: str | os.PathLike[str] | VirtualSystem,
    drive: str | os.PathLike[str] | Measurement,
    out_dir: str | os.PathLike[str],
    settings: VehicleLoopSettings,
    models: Mapping[str, str | Path] | None,
    log: Log,
    graphs: Path,
) -> VehicleLoopReport:
    """`run_vehicle_loop` with the elements' step graphs written into `graphs`."""
    system_file = system.structure.path if isinstance(system, VirtualSystem) else Path(system)
    given = (measured, system_file, drive)
    inputs = [Path(p) for p in given if p is not None and not isinstance(p, Measurement)]
    out_dir = check_output_dir(out_dir, "vehicle-loop", inputs, replaces=True)
    with VirtualSystem.open(system, settings.allow_outside) as virtual:
        car = read_virtual_car(virtual, virtual.structure.path or system_file or virtual.where, graphs, models, log)
        return _loop_on(car, measured, drive, out_dir, settings, log)


def _loop_on(
    car: VirtualCar,
    measured: str | os.PathLike[str] | Measurement,
    drive: str | os.PathLike[str] | Measurement,
    out_dir: Path,
    settings: VehicleLoopSettings,
    log: Log,
) -> VehicleLoopReport:
    """The loop on the virtual car `car` (`run_vehicle_loop`)."""
    _check_step_graphs(car)
    m = _load(measured, "measurement", _read_record)
    d = _load(drive, "drive", read_drive)
    _check_time_axes(m, d)
    step = settings.step_for(car.vehicle_fmu)
    log(f"replaying {car.name} on {d.source} at a {step:g} s step")
    base = replay_system(car.system, d, step)
    recorded = [c for c in m.names if f"derived:{c}" not in m.notes and not c.startswith("actuator_")]
    channels = [c for c in recorded if c in base.channels]
    ignored = [c for c in recorded if c not in channels]
    if not channels:
        raise VehicleLoopError(
            f"{m.source}: no measured channel is an output of the virtual car {car.ssd} (measured: "
            f"{', '.join(m.names)})"
        )
    virtual = on_record(base, m, channels, settings.settle)
    if len(virtual.time) < 16 * settings.blocks:
        raise VehicleLoopError(
            f"{m.source}: {len(virtual.time)} samples after the {settings.settle:g} s settling time are too few "
            f"(at least {16 * settings.blocks})"
        )
    record = settled(m, virtual, channels)
    scale = np.array([np.std(record[c]) for c in channels])
    flat = [c for c, s in zip(channels, scale) if not s > 0]
    if flat:
        raise VehicleLoopError(f"{m.source}: channel(s) {', '.join(flat)} do not vary; nothing to compare")
    residual = np.column_stack([(record[c] - virtual[c]) / s for c, s in zip(channels, scale)])
    candidates, untestable = _candidates(car, channels, base)
    _check_attribution_size(m.source, len(virtual.time), channels, len(candidates), settings.max_effects)
    retrainable = {e: path is not None and trained_network(path) for e, path in car.onnx.items()}
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    with staging_dir(out_dir.parent, f".{out_dir.name}.staging-") as staging:

        def replay(system: VirtualSystem) -> Measurement:
            return on_record(replay_system(system, d, step), m, channels, settings.settle)

        sensitivities = Sensitivities(car, staging / "sensitivity", replay, virtual, channels)
        columns: dict[str, list[np.ndarray]] = {}
        for key, c in candidates.items():
            check_stop()
            if c.effect == SENSOR_OFFSET:
                column = np.zeros_like(residual)
                column[:, channels.index(c.channel)] = 1.0
                columns[key] = [column]
            else:
                log(f"sensitivity of the channels to {c.key}")
                columns[key] = [s / scale for s in sensitivities.columns(c.component, c.terms, c.joint_step)]
        found = attribute(
            residual,
            channels,
            columns,
            candidates,
            settings.blocks,
            settings.alpha,
            settings.min_explained,
            settings.max_effects,
            untestable,
        )
        in_situ = {}
        for element in car.fmus:
            kind = car.kind(element)
            own = in_situ_record(m, element) if kind is not None and kind.in_situ else None
            if own is not None and retrainable[element]:
                in_situ[element] = in_situ_diagnosis(
                    own.slice(*_rows(own, settings.settle)), car.fmus[element], car.onnx[element], settings.in_situ
                )
        offsets: dict[str, float] = {}
        fixes: list[Fixed] = []
        for e in found.named:
            c = e.candidate
            if c.effect == SENSOR_OFFSET:
                offsets[c.channel] = e.coefficients[0] * float(scale[channels.index(c.channel)])
                continue
            onnx_path = car.onnx[c.component]
            own = in_situ_record(m, c.component) if retrainable[c.component] else None
            log(f"fixing {c.component}: {c.effect}")
            if own is not None:
                fixes.append(
                    fix_in_situ(
                        c.component,
                        own.slice(*_rows(own, settings.settle)),
                        onnx_path,
                        staging / "components" / c.component,
                        settings.in_situ,
                    )
                )
            else:
                fixes.append(fix_by_terms(e, onnx_path, staging / "components"))
        fixed, final, fmus = _fixed_system(car, fixes, staging)
        after_result = replay(fixed)
        corrected = Measurement(
            record.time,
            {c: record[c] - offsets.get(c, 0.0) for c in channels},
            dict(record.units),
            source=record.source,
        )
        before = channel_errors(virtual, record, channels)
        after = channel_errors(after_result, corrected, channels)
        named = found.named
        summary = verdict(named, before, after, settings.budget)
        untested = [f"{e}: {_untested_words(car, e)}" for e in car.fmus if car.onnx[e] is None]
        if untested:
            summary += "; NOT TESTED: " + ", ".join(e for e in car.fmus if car.onnx[e] is None) + " (no step graph)"
        report = VehicleLoopReport(
            measured=m.source,
            system=str(car.ssd),
            fixed_system=out_dir / final.relative_to(staging),
            fmus={k: out_dir / v.relative_to(staging) for k, v in fmus.items()},
            channels={c: {"before": before[c], "after": after[c]} for c in channels},
            attribution=found,
            fixes=[_moved(f, staging, out_dir) for f in fixes],
            offsets=offsets,
            in_situ=in_situ,
            coverage=_coverage(car, channels, retrainable),
            ignored=ignored,
            summary=summary,
            notes=list(car.graph_notes),
            untested=untested,
        )
        write_vehicle_report(staging, report, record, virtual, after_result, corrected)
        replace_output_dir(staging, out_dir, "vehicle-loop")
    return report


def _check_attribution_size(source: str, samples: int, channels: list[str], candidates: int, most: int) -> None:
    """Refuse, before any sensitivity is replayed, a record whose attribution would not fit MAX_ATTRIBUTION_BYTES:
    every candidate's design holds a column of samples x channels values per term (a sensor offset per channel makes
    that grow with the square of the channels), and forward selection copies the named ones' columns a few times
    (ATTRIBUTION_COPIES per candidate it may name, `most`, and the one it tests)."""
    size = (candidates + ATTRIBUTION_COPIES * (most + 2)) * samples * len(channels) * 8
    if size > MAX_ATTRIBUTION_BYTES:
        raise VehicleLoopError(
            f"{source}: {samples} samples of {len(channels)} channels with {candidates} candidate effects and offsets "
            f"need about {size / 1024**3:.3g} GiB to attribute, more than the limit of "
            f"{MAX_ATTRIBUTION_BYTES / 1024**3:g} GiB; give a shorter record or fewer channels"
        )


def _check_step_graphs(car: VirtualCar) -> None:
    """Refuse an element's ONNX file that is not a readable ONNX model, naming the element and the file, before
    any replay (it is read again when the element's sensitivities and fixes are built)."""
    for element, path in car.onnx.items():
        if path is not None:
            try:
                load_onnx(path)
            except FmuBuildError as error:
                raise VehicleLoopError(f"{car.ssd}: element {element!r}: {error}") from None


def _check_time_axes(record: Measurement, drive: Measurement) -> None:
    """Refuse a record whose time axis does not start where the drive's does (within half a sample of either): the
    virtual car is replayed on the drive's axis and compared sample by sample at the record's stamps, so an offset
    axis compares different instants of the run (a record stamped from 3 s against a drive from 0 s is off by 3 s)."""
    tolerance = 0.5 * min(record.sample_period, drive.sample_period)
    if abs(record.start - drive.start) > tolerance:
        raise VehicleLoopError(
            f"{record.source}: the record's time starts at {record.start:.9g} s, the drive {drive.source}'s at "
            f"{drive.start:.9g} s; the two time axes must start together (the record from the moment the drive "
            "started): shift the record's time by the difference"
        )


def verdict(
    named: list[Evidence], before: Mapping[str, ChannelError], after: Mapping[str, ChannelError], budget: float
) -> str:
    """The report's one-line summary: what was named, and whether the residual left is within the error budget (no
    channel's NRMSE above `budget`); an unexplained residual beyond it is never called consistent."""
    left = after if named else before
    beyond = sorted(((e.nrmse, c) for c, e in left.items() if not e.nrmse <= budget), reverse=True)
    words = ", ".join(f"{c} {n:.0%}" for n, c in beyond[:3]) if beyond else ""
    if named:
        summary = "named " + ", ".join(map(_named_words, named))
        if beyond:
            summary += (
                f"; after the fixes the residual is still beyond the co-simulation error budget (NRMSE {words}, "
                f"budget {budget:.0%})"
            )
        return summary
    if beyond:
        return (
            f"nothing added; NOT consistent with the co-simulation error budget: NRMSE {words} (budget {budget:.0%}) "
            "and no component effect or sensor offset explains it; check the record against the drive and the "
            "virtual car (time axis, units, channel names, sensor scaling)"
        )
    return f"nothing added; {BUDGET}"


def _named_words(e: Evidence) -> str:
    """'effect on component', with the candidates these channels cannot tell from it."""
    words = f"{e.candidate.effect} on {e.candidate.component}"
    if e.alike:
        words += f" (these channels cannot tell it apart from {' or '.join(k.replace(':', ' ') for k in e.alike)})"
    return words


def _rows(m: Measurement, settle: float) -> tuple[int, int]:
    """(start, stop) of the samples after the settling time."""
    return int(np.searchsorted(m.time, m.time[0] + settle - 1e-12)), len(m.time)


def _moved(fixed: Fixed, staging: Path, out_dir: Path) -> Fixed:
    """`fixed` with its paths where they lie once the staging folder became `out_dir`."""

    def final(path: Path) -> Path:
        try:
            return out_dir / path.relative_to(staging)
        except ValueError:
            return path

    return Fixed(fixed.element, final(fixed.fmu), final(fixed.onnx), fixed.method, fixed.loop)


def _fixed_system(car: VirtualCar, fixes: list[Fixed], staging: Path) -> tuple[VirtualSystem, Path, dict[str, Path]]:
    """The fixed system, written as staging/system/SystemStructure.ssd with every FMU copied beside it (the fixed
    ones in their elements' places), and element -> FMU path in the staging folder."""
    folder = staging / "system"
    (folder / "fmu").mkdir(parents=True, exist_ok=True)
    chosen = {name: fmu for name, fmu in car.fmus.items()} | {f.element: f.fmu for f in fixes}
    copies: dict[Path, Path] = {}
    fmus = {}
    for element, source in chosen.items():
        if source not in copies:
            target = folder / "fmu" / (f"{element}-{source.name}" if source in {f.fmu for f in fixes} else source.name)
            shutil.copyfile(source, target)
            copies[source] = target
        fmus[element] = copies[source]
    vehicle = folder / "fmu" / car.vehicle_fmu.name
    shutil.copyfile(car.vehicle_fmu, vehicle)
    fixed = car.swapped(fmus | {car.vehicle: vehicle}, "fixed by nnfmu loop vehicle")
    return fixed, fixed.write(folder), fmus
