"""`run_road_test`: the thesis's virtual road test simulator runs with network FMUs against the monolithic reference.

drive file (ISO 8608 road) -> component and vehicle FMUs -> SSP systems -> co-simulation with the spline and with the
hysteresis damper network (the full vehicle with its four front LCA bushing networks in the loop as well, coupled
through the vehicle's stabilised ports, see `systems`), and with the truth physics as FMUs in the networks' place ->
monolithic reference (truth physics, no coupling) -> the error budget per channel (`budget`: total, the networks'
own share, the coupling's share, damage ratio), validation report per system with the thesis comparison table ->
`road_test.json`. Every network's input is checked against its training envelope along the reference's motion and
the co-simulations'. The co-simulations use the master's defaults and the FMUs theirs: what a user gets.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from nnfmu.atomic import write_text_atomic
from nnfmu.component import Component
from nnfmu.cosim import DEFAULT_STEP, CosimSettings
from nnfmu.data import Measurement, save_measurement
from nnfmu.data.drive_files import write_drive
from nnfmu.data.rigs import BUSHING_CHANNELS
from nnfmu.errors import NnfmuError
from nnfmu.validate import ChannelComparison, Target, ValidationSettings, compare, write_report
from nnfmu.vehicle import DriveSettings, generate_drive
from nnfmu.workflows.characterise.linked import LinkedCharacterisation, characterise_models
from nnfmu.workflows.characterise.settings import CharacteriseSettings
from nnfmu.workflows.passivity import passivity_warnings
from nnfmu.workflows.roadtest.budget import BudgetRow, budget_rows
from nnfmu.workflows.roadtest.envelope import Excursion, envelope_warnings, excursions
from nnfmu.workflows.roadtest.open_loop import network_errors
from nnfmu.workflows.roadtest.report import write_system_report
from nnfmu.workflows.roadtest.stabilisers import bushing_stabilisers
from nnfmu.workflows.roadtest.systems import (
    DAMPER_MODELS,
    ComponentFmus,
    RoadTestError,
    build_component_fmus,
    build_truth_fmus,
    build_vehicle,
    bushing_elements,
    check_models,
    damper_elements,
    road_test_system,
    vehicle_components,
)
from nnfmu.workflows.roadtest.thesis import ThesisRow, model_verdicts, thesis_row
from nnfmu.workflows.roadtest.truth_reference import Reference, monolithic_reference
from nnfmu.workflows.system import FmuCache, VirtualSystem

COMPARED = {
    "quarter-car": (
        "damper_force",
        "damper_displacement",
        "damper_velocity",
        "body_acceleration",
        "spindle_acceleration",
        "spindle_vertical_force",
    ),
    "full-vehicle": (
        "damper_fl_force",
        "damper_fl_displacement",
        "damper_rl_force",
        "lca_fl_angle",
        "body_heave",
        "body_pitch",
        "body_acceleration_fl",
        "spindle_fl_acceleration",
        "spindle_fl_vertical_force",
        "bushing_fl_front_axial_displacement",
        "bushing_fl_front_radial_displacement",
        "bushing_fl_front_axial_force",
        "bushing_fl_front_radial_force",
        "bushing_fl_front_axial_torque",
        "bushing_fl_front_conical_torque",
    ),
}
BUSHING_NETWORK = "lca-bushing"  # the four bushing networks merged into one FMU (`build_component_fmus`)
TRUTH = "truth physics"  # the co-simulation with the truth laws as FMUs in the networks' place
Log = Callable[[str], None]


@dataclass(frozen=True)
class SystemRun:
    """How one system runs: `duration` [s] of drive, communication `step` [s], coupling `iterations` (0: plain
    Gauss-Seidel), network output low-pass `filter_cutoff` [Hz] (None: the FMUs' default, off; 0: off), `channels`
    compared with the reference (empty: the system's default set, `COMPARED`)."""

    duration: float
    step: float = DEFAULT_STEP
    iterations: int = 0
    filter_cutoff: float | None = None
    channels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise RoadTestError(f"duration {self.duration!r} s must be a positive number")


@dataclass(frozen=True)
class RoadTestSettings:
    """Which systems run and how (None: skipped); the road (ISO 8608 class, speed [m/s], seed, drive sample rate
    [Hz]); the reference's RK4 step [s]; the time-history plot `window` [s] (the thesis's 30-35 s), used when the
    drive covers it; `fade_in` [s]: the drive rises from rest over its first seconds (`DriveSettings.fade_in`), as
    the car starts at rest: the road's height at t = 0 kicked the LCA and its bushing networks out of their training
    envelope, which locked vehicle-trained bushing networks into a 125 Hz oscillation for the whole drive. `target`:
    the NRMSE each system report's verdict judges each damper model's worst channel by (5 % by default).
    `characterise`: the standard tests each network FMU is characterised with into `characterise/<network>/`, which
    the system reports link to (None: none)."""

    quarter_car: SystemRun | None = SystemRun(50.0)
    full_vehicle: SystemRun | None = SystemRun(50.0)
    road_class: str = "C"
    speed: float = 20.0
    seed: int = 0
    sample_rate: float = 1000.0
    reference_step: float = 1e-4
    window: tuple[float, float] = (30.0, 35.0)
    fade_in: float = 0.5
    target: Target = Target()
    characterise: CharacteriseSettings | None = CharacteriseSettings()

    def runs(self) -> dict[str, SystemRun]:
        chosen = {"quarter-car": self.quarter_car, "full-vehicle": self.full_vehicle}
        return {name: run for name, run in chosen.items() if run is not None}


@dataclass
class SystemResult:
    """One system's outcome: its SSP files, report, thesis table, error budget, envelope check, run times [s] and
    the simulated duration [s]."""

    system: str
    ssds: dict[str, Path]
    report: Path
    rows: list[ThesisRow]
    budget: list[BudgetRow]
    excursions: list[Excursion]
    seconds: dict[str, float]
    duration: float
    target: Target = Target()
    characterisations: dict[str, LinkedCharacterisation] = field(default_factory=dict)
    systems: dict[str, VirtualSystem] = field(default_factory=dict)  # by damper model, each read from its SSD

    def to_dict(self) -> dict[str, object]:
        return {
            "system": self.system,
            "verdicts": model_verdicts(self.rows, self.target),
            "target": {"nrmse": self.target.nrmse, "source": self.target.source},
            "ssds": {k: str(v) for k, v in self.ssds.items()},
            "report": str(self.report),
            "duration_s": self.duration,
            "seconds": {k: round(v, 2) for k, v in self.seconds.items()},
            "thesis_table": [r.to_dict() for r in self.rows],
            "budget": [r.to_dict() for r in self.budget],
            "envelope": [e.to_dict() for e in self.excursions],
            "characterisations": {k: v.describe() for k, v in self.characterisations.items()},
        }


@dataclass
class RoadTestResult:
    """Everything `run_road_test` wrote: the drive file, per-system results, `road_test.json`, total time [s]."""

    out: Path
    drive: Path
    systems: list[SystemResult] = field(default_factory=list)
    summary: Path | None = None
    seconds: float = 0.0

    def reports(self) -> dict[str, Path]:
        return {s.system: s.report for s in self.systems}

    def system(self, system: str, model: str) -> VirtualSystem:
        """The system `system` co-simulated with damper `model`, in memory; RoadTestError if it was not run."""
        self.ssd(system, model)
        return next(s.systems[model] for s in self.systems if s.system == system)

    def ssd(self, system: str, model: str) -> Path:
        """The SSP system file of `system` co-simulated with damper `model`; RoadTestError if it was not run."""
        found = {(s.system, m): path for s in self.systems for m, path in s.ssds.items()}
        if (system, model) not in found:
            raise RoadTestError(f"the road test in {self.out} has no {system} with {model} (has: {sorted(found)})")
        return found[system, model]


def system_folder(out: Path, system: str, model: str) -> Path:
    """The folder `run_road_test` (into `out`) writes the SSP system of `system` with damper `model` into."""
    return out / "systems" / system / model.replace(" ", "-")


def _stretch(drive: Measurement, duration: float) -> Measurement:
    """The first `duration` seconds of the drive (every sample with t <= duration)."""
    n = int(np.searchsorted(drive.time, drive.time[0] + duration * (1 + 1e-12), side="right"))
    return drive.slice(0, max(n, 2))


def _on_reference(result: Measurement, reference: Measurement, channels: list[str], source: str) -> Measurement:
    """`channels` of `result` interpolated onto the reference's time stamps inside both spans."""
    keep = (reference.time >= result.time[0] - 1e-12) & (reference.time <= result.time[-1] + 1e-12)
    time = reference.time[keep]
    return Measurement(
        time=time,
        channels={c: np.interp(time, result.time, result[c]) for c in channels},
        units={c: result.units[c] for c in channels},
        source=source,
    )


def _settings(window: tuple[float, float], span: float) -> ValidationSettings:
    return ValidationSettings(window=window if window[1] <= span else None)


def _cosim(system: VirtualSystem, drive: Measurement, run: SystemRun) -> tuple[Measurement, float]:
    """The system co-simulated in memory on `drive` as `run` says, and the wall time it took [s]."""
    started = time.perf_counter()
    result = system.cosimulate(drive, CosimSettings(step=run.step, iterations=run.iterations, tolerance=1e-6))
    return result.measurement, time.perf_counter() - started


def _unfit_stabilisers(system: str, stabilisers: Mapping[str, tuple[float, float]], error: Exception) -> str:
    """Why the truth physics' co-simulation can fail where the vehicle's ports carry elements fitted to the networks,
    with the fitted element of each bushing channel (the same for every bushing)."""
    elements = []
    for channel in BUSHING_CHANNELS.values():
        fitted = next((e for port, e in stabilisers.items() if port.endswith(f"_{channel.force}")), None)
        if fitted is not None:
            force, position = channel.force_unit, channel.position_unit
            elements.append(f"{channel.force} {fitted[0]:.4g} {force}/{position}, {fitted[1]:.4g} {force}.s/{position}")
    return (
        f"{system}: the co-simulation with the truth physics as FMUs (the coupling's reference) failed: {error}. "
        "The vehicle's stabilised bushing ports carry elements fitted to the bushing networks "
        f"({'; '.join(elements)}); a network far from the bushing's own incremental stiffness and damping (an "
        "under-trained one, say) makes them unfit, and the loop can then diverge with the truth physics in it too: "
        "train the bushing networks further and check their test error (docs/known-limits.md)"
    )


def _carried(cache: FmuCache, fmu: Path) -> Component:
    """The component description the network FMU `fmu` carries (read once per road test, `cache`)."""
    component = cache.read(fmu).component
    if component is None:
        raise RoadTestError(f"{fmu}: the network FMU records no step graph; rebuild it with nnfmu build")
    return component


def _run_system(
    system: str,
    run: SystemRun,
    fmus: ComponentFmus,
    truth: ComponentFmus,
    drive: Measurement,
    settings: RoadTestSettings,
    out: Path,
    log: Log,
    characterised: Mapping[str, LinkedCharacterisation],
    cache: FmuCache,
) -> SystemResult:
    """One system: FMUs and SSDs, reference, both damper networks and the truth physics co-simulated and compared,
    the error budget, the envelope checks, the report (linking the characterisations of the system's networks)."""
    drive = _stretch(drive, run.duration)
    bushings = bool(bushing_elements(system))
    graph = cache.graph(fmus.bushing) if bushings and fmus.bushing is not None else None
    stabilisers = bushing_stabilisers(graph, bushing_elements(system)) if graph is not None else {}
    for line in passivity_warnings(BUSHING_NETWORK, graph) if graph is not None else []:
        log(f"warning: {line}")
    vehicle = build_vehicle(system, out / "fmu", run.step, stabilisers)
    parts = {model: (fmus.dampers[model], fmus.bushing) for model in DAMPER_MODELS}
    parts[TRUTH] = (truth.dampers["truth"], truth.bushing)
    systems = {
        model: road_test_system(
            system, vehicle, damper, bushing if bushings else None, run.filter_cutoff if model != TRUTH else None, cache
        )
        for model, (damper, bushing) in parts.items()
    }
    ssds = {model: virtual.write(system_folder(out, system, model)) for model, virtual in systems.items()}
    systems = {model: virtual.read_from(ssds[model]) for model, virtual in systems.items()}
    seconds: dict[str, float] = {}
    log(f"{system}: monolithic reference over {run.duration:g} s (truth physics, RK4 at {settings.reference_step:g} s)")
    reference: Reference = monolithic_reference(system, drive, vehicle_components(system), settings.reference_step)
    seconds["reference"] = reference.seconds
    ref = reference.measurement
    validation = _settings(settings.window, float(ref.time[-1] - ref.time[0]))
    results_dir = out / "results" / system
    save_measurement(ref, results_dir / "reference.csv")
    channels = list(run.channels or COMPARED[system])
    cosims: dict[str, Measurement] = {}
    comparisons: dict[str, list[ChannelComparison]] = {}
    used: list[Excursion] = []
    for model in ssds:
        try:
            result, seconds[model] = _cosim(systems[model], drive, run)
        except NnfmuError as error:  # the master's CosimError, an FMU's FmiStatusError
            if model != TRUTH or not stabilisers:
                raise
            raise RoadTestError(_unfit_stabilisers(system, stabilisers, error)) from error
        log(f"{system} with {model}: co-simulated {run.duration:g} s at {run.step:g} s in {seconds[model]:.1f} s")
        cosims[model] = _on_reference(result, ref, channels, f"{system} co-simulation with {model}")
        save_measurement(cosims[model], results_dir / f"{model.replace(' ', '-')}.csv")
        comparisons[model] = compare(cosims[model], ref, channels, validation)
        if model != TRUTH:
            used.extend(
                excursions(
                    f"co-simulation with {model}",
                    damper_elements(system),
                    _carried(cache, fmus.dampers[model]),
                    result,
                )
            )
    rows = [thesis_row(c, model) for model in DAMPER_MODELS for c in comparisons[model]]
    rows.sort(key=lambda row: (channels.index(row.channel), DAMPER_MODELS.index(row.model)))  # side by side
    budget = [
        row
        for model in DAMPER_MODELS
        for row in budget_rows(
            system,
            model,
            comparisons[model],
            comparisons[TRUTH],
            network_errors(system, model, fmus, ref, cosims[model], cosims[TRUTH], channels, validation),
        )
    ]
    reference_ports = _carried(cache, fmus.dampers[DAMPER_MODELS[0]])
    used.extend(excursions("reference", damper_elements(system), reference_ports, ref))
    if bushings and fmus.bushing is not None:
        used.extend(
            excursions(
                "reference",
                bushing_elements(system),
                _carried(cache, fmus.bushing),
                ref,
            )
        )
    for line in envelope_warnings(system, used):
        log(f"warning: {line}")
    report_dir = out / "report" / system
    model_reports = {
        model: write_report(
            chosen,
            report_dir / model.replace(" ", "-"),
            f"{system}: {model} vs the monolithic reference",
            {"system": system, "drive": drive.source},
            settings.target,
        )
        for model, chosen in comparisons.items()
    }
    networks = [*DAMPER_MODELS, *([BUSHING_NETWORK] if bushings else [])]
    outcome = SystemResult(
        system,
        ssds,
        report_dir / "index.html",
        rows,
        budget,
        used,
        seconds,
        run.duration,
        settings.target,
        {k: characterised[k] for k in networks if k in characterised},
        systems,
    )
    write_system_report(
        outcome.to_dict(),
        _context(system, run, settings, drive),
        model_reports,
        outcome.report,
        outcome.characterisations,
    )
    return outcome


def _characterise(
    fmus: ComponentFmus, folder: Path, settings: CharacteriseSettings | None, log: Log
) -> dict[str, LinkedCharacterisation]:
    """Each network FMU's standard tests into `folder`/<network> (none when `settings` is None)."""
    if settings is None:
        return {}
    networks = {**fmus.dampers, **({BUSHING_NETWORK: fmus.bushing} if fmus.bushing is not None else {})}
    started = time.perf_counter()
    found = characterise_models(networks, folder, settings, log)
    log(f"characterised {len(networks)} network FMU(s) in {time.perf_counter() - started:.1f} s")
    return found


def _context(system: str, run: SystemRun, settings: RoadTestSettings, drive: Measurement) -> dict[str, str]:
    return {
        "system": system,
        "drive": f"{drive.source}, {run.duration:g} s at {settings.sample_rate:g} Hz, faded in from rest over "
        f"{settings.fade_in:g} s",
        "co-simulation": f"fmpy master at its defaults (Gauss-Seidel, vehicle first, linear extrapolation, refresh "
        f"at every communication point), step {run.step:g} s, iterations {run.iterations}, network "
        "output filter "
        f"{'the FMU default (off)' if run.filter_cutoff is None else f'{run.filter_cutoff:g} Hz'}"
        f"; vehicle FMU exact at {run.step:g} s, inputs interpolated",
        "reference": f"monolithic RK4 at {settings.reference_step:g} s, rig truth physics in every network's place",
        "front LCA bushings": "networks in the loop through stabilised ports (the vehicle holds only each network's "
        "deviation from a linear bushing over a step, that bushing fitted to the networks' stiffness and damping "
        "over a sample along their reference stimulus)"
        if system == "full-vehicle"
        else "none (quarter car)",
        "error budget": "total: network FMUs in the co-simulation; network: a network replayed open loop along the "
        "reference motion of its element (vehicle channels: network vs truth co-simulation); "
        "coupling: truth-physics FMUs in the same co-simulation; all against the reference",
    }


def run_road_test(
    out: str | Path, models: Mapping[str, str | Path], settings: RoadTestSettings = RoadTestSettings(), log: Log = print
) -> RoadTestResult:
    """Run the road test of every system in `settings` into `out` (drive.csv, fmu/, systems/, results/, report/,
    road_test.json). `models` maps 'damper-spline', 'damper-hysteresis' and (for the full vehicle) the four
    'bushing-*' presets to ONNX step graphs. Raises RoadTestError for a missing model or bad settings."""
    started = time.perf_counter()
    out = Path(out)
    models = {k: Path(v) for k, v in models.items()}
    runs = settings.runs()
    if not runs:
        raise RoadTestError("no system to run: both quarter_car and full_vehicle are None")
    for system in runs:
        check_models(models, system)
    drive = generate_drive(
        DriveSettings(
            road_class=settings.road_class,
            speed=settings.speed,
            seed=settings.seed,
            duration=max(r.duration for r in runs.values()) + 1 / settings.sample_rate,
            sample_rate=settings.sample_rate,
            fade_in=settings.fade_in,
        )
    )
    drive_path = write_drive(drive, out / "drive.csv")
    log(f"drive file {drive_path}: ISO 8608 class {settings.road_class} at {settings.speed:g} m/s")
    fmus = build_component_fmus(models, out / "fmu", "full-vehicle" in runs)
    cache = FmuCache()  # each network FMU's step graph and description, read once
    period = _carried(cache, fmus.dampers[DAMPER_MODELS[0]]).sample_period
    truth = build_truth_fmus(
        out / "fmu", period if period is not None else min(r.step for r in runs.values()), "full-vehicle" in runs
    )
    outcome = RoadTestResult(out=out, drive=drive_path)
    characterised = _characterise(fmus, out / "characterise", settings.characterise, log)
    for system, run in runs.items():
        system_run = _run_system(system, run, fmus, truth, drive, settings, out, log, characterised, cache)
        outcome.systems.append(system_run)
    outcome.seconds = time.perf_counter() - started
    outcome.summary = out / "road_test.json"
    write_text_atomic(
        outcome.summary,
        json.dumps(
            {
                "drive": str(drive_path),
                "seconds": round(outcome.seconds, 1),
                "settings": asdict(settings),
                "systems": [s.to_dict() for s in outcome.systems],
            },
            indent=2,
            allow_nan=False,
        ),
    )
    return outcome
