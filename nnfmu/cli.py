"""The `nnfmu` command line: each command parses its options, calls one function and prints the outcome.

Imports of the working stages happen inside the commands, so `nnfmu build` never loads torch.
"""

from __future__ import annotations

import signal
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Literal, Optional, Union

import click
import typer
from typer.core import TyperGroup

from nnfmu.errors import NnfmuError, SettingsError
from nnfmu.out_paths import check_output_file
from nnfmu.stopping import clear_stop, request_stop, stop_requested
from nnfmu.workflows.defaults import DEFAULT_STEP


class _Commands(TyperGroup):
    """The top-level commands; `nnfmu loop vehicle ...` is the command `loop-vehicle` (the component loop takes a
    measurement file as its first argument, so a file named `vehicle` is given as `./vehicle`)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args[:2] == ["loop", "vehicle"]:
            args = ["loop-vehicle", *args[2:]]
        return super().parse_args(ctx, args)


def _interrupt(signum: int, frame: object) -> None:
    """Turn SIGTERM (and SIGINT) into the KeyboardInterrupt of Ctrl-C, so the same cleanup runs (temporary files and
    folders); the request is remembered (`nnfmu.stopping`), so a run whose interrupt a library swallowed still
    publishes nothing and stops at its next check."""
    request_stop(f"signal {signum}")
    raise KeyboardInterrupt(f"signal {signum}")


class _Nnfmu(typer.Typer):
    """The `nnfmu` program: SIGTERM stops it as Ctrl-C does from before the arguments are parsed, even where the
    parent left SIGTERM ignored (an inherited SIG_IGN made a run carry on to a complete result after two SIGTERMs),
    and an interrupt anywhere ends in exit status 130."""

    def __call__(self, *args: object, **kwargs: object) -> object:
        main = threading.current_thread() is threading.main_thread()
        clear_stop()
        if main:
            previous = signal.signal(signal.SIGTERM, _interrupt)
            if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
                signal.signal(signal.SIGINT, _interrupt)
        try:
            return super().__call__(*args, **kwargs)
        except KeyboardInterrupt:
            raise SystemExit(130) from None
        except SystemExit as done:
            if stop_requested() is not None and done.code in (0, None):
                raise SystemExit(130) from None  # stopped, though a library swallowed the interrupt
            raise
        finally:
            if main:  # the work is over: a signal during interpreter shutdown ends the process at once
                signal.signal(signal.SIGTERM, previous if callable(previous) else signal.SIG_DFL)
                if signal.getsignal(signal.SIGINT) is _interrupt:
                    signal.signal(signal.SIGINT, signal.default_int_handler)


app = _Nnfmu(
    cls=_Commands,
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,
    help="Neural-network component models from rig data, shipped as FMI co-simulation FMUs.",
)
data_app = typer.Typer(no_args_is_help=True, help="Inspect rig data files.")
app.add_typer(data_app, name="data")
vehicle_app = typer.Typer(no_args_is_help=True, help="Vehicle models for the virtual road test simulator.")
app.add_typer(vehicle_app, name="vehicle")
drive_app = typer.Typer(no_args_is_help=True, help="Drive files for a four-post road test simulator.")
app.add_typer(drive_app, name="drive")
controller_app = typer.Typer(no_args_is_help=True, help="Controllers of semi-active dampers, as FMUs.")
app.add_typer(controller_app, name="controller")
system_app = typer.Typer(no_args_is_help=True, help="SSP systems as one FMU with nnfmu's coupling inside.")
app.add_typer(system_app, name="system")
# `nnfmu loop`'s before -> after lines: (key of the report's errors, label, scale); NRMSE in per cent as the headline.
LOOP_ERRORS = (
    ("nrmse", "NRMSE [%]", 100.0),
    ("r2", "R²", 1.0),
    ("peak_error", "peak error [SI]", 1.0),
    ("pseudo_damage_ratio", "pseudo-damage ratio", 1.0),
)


# One helper per option several commands share, so its name, default and help read the same everywhere.
def _allow_outside_option() -> Any:
    return typer.Option(
        False,
        help="Load FMUs (and, for a campaign, drives and systems) from outside the system's or campaign's folder; an "
        "FMU is native code, so this is asked for explicitly.",
    )


def _fmi_option() -> Any:
    return typer.Option(2, "--fmi", help="FMI version: 2 or 3.")


def _backend_option() -> Any:
    return typer.Option("native", help="native (generated C, no Python at run time) or pythonfmu (onnxruntime).")


def _platforms_option() -> Any:
    return typer.Option(
        None,
        help="Binaries of the native backend, comma-separated: host, all, or FMI platforms x86_64-linux (linux64), "
        "aarch64-linux, x86_64-windows (win64), x86_64-darwin (darwin64), aarch64-darwin (default: every platform "
        "a compiler here builds; pip install 'nnfmu[cross]' brings Zig, which builds them all).",
    )


def _map_option() -> Any:
    return typer.Option(
        None,
        "--map",
        help='Rename a file channel to an nnfmu channel, e.g. --map "Axial Force=force" (repeat); '
        "for MTS exports also picks the time axis (NAME=time).",
    )


def _rpc_data_type_option() -> Any:
    return typer.Option("int16", help="RPC III sample type: int16 or float32.")


def _step_option(text: str) -> Any:
    """`--step`: a co-simulation's communication step, defaulting to the master's (`nnfmu.cosim.DEFAULT_STEP`)."""
    return typer.Option(DEFAULT_STEP, help=text)


@app.callback()
def _on_start() -> None:
    """Handle SIGTERM as SIGINT for every command (a scheduler's, a container's or kill's stop signal), also where
    the commands are invoked in-process (unless the embedding program chose its own handler)."""
    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
        signal.signal(signal.SIGTERM, _interrupt)


def _fail(error: NnfmuError) -> None:
    """Print an error in the user's input or environment as one `error:` line and exit with status 2.

    Commands pass only NnfmuError here: any other exception is a programming error and keeps its traceback."""
    typer.echo(f"error: {error}", err=True)
    raise typer.Exit(code=2)


@contextmanager
def _user_errors() -> Iterator[None]:
    """A command's work: an NnfmuError raised inside the block ends the command through `_fail`."""
    try:
        yield
    except NnfmuError as error:
        _fail(error)


def _split(items: Optional[list[str]]) -> list[str]:
    """Accept repeated options and comma-separated lists alike."""
    return [n.strip() for item in items or [] for n in item.split(",") if n.strip()]


def _platforms(items: Optional[list[str]]) -> Optional[tuple[str, ...]]:
    """`--platforms host` or `--platforms x86_64-linux,win64` as a tuple; None (the default choice) when not given."""
    return tuple(_split(items)) if items else None


@contextmanager
def _warnings_as_lines(*categories: type[Warning]) -> Iterator[None]:
    """Print each distinct warning of `categories` (default: a build's platform left out) raised inside the block
    as one `warning: ...` line on stderr; other warnings pass on as Python shows them."""
    from nnfmu.workflows.fmu_build import PlatformSkippedWarning

    categories = categories or (PlatformSkippedWarning,)
    with warnings.catch_warnings(record=True) as caught:
        for category in categories:
            warnings.simplefilter("always", category)
        try:
            yield
        finally:
            lines = []
            for w in caught:
                if issubclass(w.category, categories):
                    lines.append(str(w.message))
                else:
                    warnings.showwarning(w.message, w.category, w.filename, w.lineno)
            for message in dict.fromkeys(lines):
                typer.echo(f"warning: {message}", err=True)


@app.command()
def rig(
    kind: str = typer.Argument(..., help="Rig to simulate: damper (dyno) or bushing (four-channel rig)."),
    out: str = typer.Option(..., "--out", "-o", help="Data file (.csv or .mf4); the truth file goes beside it."),
    sample_rate: float = typer.Option(1000.0, help="Sample rate [Hz]."),
    duration: Optional[float] = typer.Option(
        None, help="Record length [s] (default: damper 70, bushing 80 lab, 60 random or sine)."
    ),
    seed: int = typer.Option(0, help="Seed for excitation and sensor noise."),
    noise: float = typer.Option(1.0, help="Multiplier of the realistic sensor noise (0: exact values)."),
    effects: Optional[str] = typer.Option(
        None, help="Comma-separated effects to switch on, or 'none' (default: the kind's defaults)."
    ),
    excitation: Optional[str] = typer.Option(
        None,
        help="lab (default: sine series + random), random (held-out test data), sine, or vehicle (with --drive-from).",
    ),
    drive_from: Optional[Path] = typer.Option(
        None,
        "--drive-from",
        help="A vehicle result (co-simulation or monolithic reference) whose bushing deflections (bushing rig) or damper strokes (damper dyno: after its sine series, run up to the first level at or above --margin times the car's fastest stroke rate [m/s]) the drive is derived from.",
    ),
    element: Optional[list[str]] = typer.Option(
        None,
        help="With --drive-from: element(s) to derive the drive from, e.g. bushing_fl_front or damper_fl (repeat or comma-separate; the envelope covers them all).",
    ),
    margin: float = typer.Option(
        1.2, help="With --drive-from: the drive's excursions over the simulated ones on each side of the working point."
    ),
    band: Optional[str] = typer.Option(
        None,
        help="With --drive-from: the rig controller's pass band LOW:HIGH [Hz] (default: bushing rig 0.5:40, damper dyno 0.5:100).",
    ),
    default_sensors: bool = typer.Option(
        False,
        "--default-sensors",
        help="Bushing rig with --drive-from: record with the rig's default transducers instead of ranges sized for the test (the damper dyno always records with its own).",
    ),
    damper_type: str = typer.Option(
        "passive",
        "--type",
        help="Damper dyno: passive (default), mr (magnetorheological, records the coil's voltage [V]) or cdc (continuously controlled valve, records the valve current [A]).",
    ),
) -> None:
    """Simulate a lab rig and write realistic "measured" data plus a separate truth file."""
    from nnfmu.workflows.rig import RigOptions, write_rig_record

    chosen = None if effects is None else () if effects.strip() == "none" else tuple(_split([effects]))
    vehicle = drive_from is not None or excitation == "vehicle"
    with _user_errors():
        options = RigOptions(
            sample_rate=sample_rate,
            duration=duration,
            seed=seed,
            noise=noise,
            effects=chosen,
            excitation=excitation or ("vehicle" if vehicle else "lab"),
            damper_type=damper_type,
        )
        target = check_output_file(out, [drive_from] if drive_from is not None else [])
        data_path, truth_path = write_rig_record(
            kind, target, options, drive_from, _split(element), margin, band, not default_sensors
        )
    typer.echo(f"data: {data_path}\ntruth (for evaluation only, never for training): {truth_path}")


def _channel_map(items: Optional[list[str]]) -> dict[str, str]:
    """`--map "FILE CHANNEL=name"` options as a channel map."""
    from nnfmu.workflows.data_check import parse_channel_map

    try:
        return parse_channel_map(items or [])
    except SettingsError as error:
        raise typer.BadParameter(f"--map: {error}") from None


def _int_list(items: Optional[list[str]], option: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in _split(items))
    except ValueError:
        raise typer.BadParameter(f"{option}: give whole numbers, e.g. 0,1,2") from None


def _moving_mass(text: Optional[str]) -> Union[float, Literal["auto"], None]:
    """`--moving-mass`: a mass [kg], `auto`, or None when not given."""
    if text is None or text.strip().lower() == "auto":
        return None if text is None else "auto"
    try:
        return float(text)
    except ValueError:
        raise typer.BadParameter(f"--moving-mass: give a mass in kg (e.g. 2.0) or auto, not {text!r}") from None


@app.command()
def train(
    data: Path = typer.Argument(..., help="Rig data (CSV with `name [unit]` headers, MDF4, or an MTS 793 export)."),
    preset: str = typer.Option(
        ...,
        help="damper-spline, damper-hysteresis, damper-semiactive, bushing-axial-force, bushing-radial-force, bushing-axial-torque or bushing-conical-torque.",
    ),
    out: str = typer.Option(..., "--out", "-o", help="ONNX step graph to write."),
    output: Optional[str] = typer.Option(None, help="Output channel (default: the preset's, e.g. force)."),
    inputs: Optional[list[str]] = typer.Option(
        None, help="Input channels replacing the preset's (comma-separated or repeated)."
    ),
    delays: Optional[list[str]] = typer.Option(None, help="Sample delays for every input, e.g. 0,1,2."),
    hidden: Optional[list[str]] = typer.Option(
        None, help="Hidden size, or several to choose among by validation error."
    ),
    recurrent: bool = typer.Option(False, help="GRU network instead of the time-delay perceptron."),
    thesis: bool = typer.Option(
        False, help="The thesis's network exactly: its inputs, delays and fixed hidden size, trained as trainlm does."
    ),
    select_inputs: bool = typer.Option(
        False, help="Choose inputs by sensitivity analysis over the candidate taps; prints the ranking."
    ),
    optimizer: Optional[str] = typer.Option(None, help="auto, lm (Levenberg-Marquardt), adam or lbfgs."),
    restarts: Optional[int] = typer.Option(
        None, help="Training restarts per hidden size; the best validation error is kept."
    ),
    max_epochs: Optional[int] = typer.Option(None, help="Epoch limit (early stopping usually ends sooner)."),
    seed: int = typer.Option(0, help="Seed: the same seed gives the same network."),
    name: str = typer.Option("", help="Model name stored in the ONNX metadata (default: from the preset)."),
    channel_map: Optional[list[str]] = _map_option(),
    moving_mass: Optional[str] = typer.Option(
        None,
        help="Dyno mass [kg] between load cell and actuator (rod, piston, fixture): subtracted from the force as m·a before training, as a dyno's mass compensation does; 0: none (the force trained as measured); auto or default: for damper-spline and damper-hysteresis estimated from the record, reported, and subtracted where its 95 % interval excludes 0 kg (docs/moving-mass.md); other presets: nothing subtracted unless a mass is given.",
    ),
    input_cutoff: Optional[float] = typer.Option(
        None,
        help="Low-pass [Hz] of the input channels, zero phase, before the features (transducer noise above the rig's band); 0: none; default: the preset's (bushings 100 Hz, dampers none).",
    ),
) -> None:
    """Train a component network on rig data and export it as a verified ONNX step graph."""
    from rich.console import Console
    from rich.progress import Progress
    from rich.table import Table
    from rich.text import Text

    from nnfmu.workflows.tables import metrics_table
    from nnfmu.workflows.train import TrainRequest, train_from_file, trained_range

    request = TrainRequest(
        preset=preset,
        output=output,
        inputs=tuple(_split(inputs)),
        delays=_int_list(delays, "--delays"),
        hidden=_int_list(hidden, "--hidden"),
        recurrent=recurrent,
        thesis=thesis,
        restarts=restarts,
        seed=seed,
        max_epochs=max_epochs,
        select_inputs=select_inputs,
        optimizer=optimizer,
        name=name,
        channel_map=tuple(_channel_map(channel_map).items()),
        moving_mass=_moving_mass(moving_mass),
        input_cutoff=input_cutoff,
    )
    console = Console(markup=False)  # feature and channel names carry brackets: velocity[k]
    with _user_errors(), Progress(console=console, transient=True) as bar:
        task = bar.add_task("training", total=1.0)
        outcome = train_from_file(
            data,
            request,
            check_output_file(out, [data]),
            lambda what, done: bar.update(task, description=what, completed=done),
        )
    if outcome.selection is not None:
        ranking = Table(title="input sensitivity ranking (validation MSE increase when shuffled)")
        ranking.add_column("feature")
        ranking.add_column("increase", justify="right")
        for feature, increase in outcome.selection.ranking:
            ranking.add_row(feature, f"{increase:.4g}")
        console.print(ranking)
        console.print(f"chosen inputs: {', '.join(outcome.selection.chosen)}")
    spec = outcome.model.spec
    console.print(f"{preset}: {', '.join(spec.feature_names)} -> {spec.output}")
    console.print(metrics_table({split: m.as_dict() for split, m in outcome.metrics.items()}))
    if len(outcome.trials) > 1:
        console.print(
            "hidden size by validation MSE (scaled): "
            + ", ".join(f"{trial.hidden}: {trial.validation_mse:.3g}" for trial in outcome.trials)
        )
    for note in [*outcome.data_notes, *outcome.training_notes]:
        console.print(f"note: {note}")
    console.print(Text(trained_range(outcome.model)))
    for warning in outcome.warnings:
        console.print(Text("warning: ", style="yellow") + Text(warning))
    console.print(
        f"ONNX: {outcome.path} (onnxruntime vs torch max relative error "
        f"{outcome.export.max_relative_error:.2g}); {outcome.seconds:.1f} s"
    )


@app.command()
def demo(
    out: Path = typer.Option(Path("demo-out"), "--out", "-o", help="Folder for everything the demo writes."),
    seed: int = typer.Option(0, help="Seed of the rig records and the training."),
    quick: bool = typer.Option(
        False,
        help="Short records and trainings, every stage in about half a minute on 2 idle cores: checks every stage runs, not results to quote.",
    ),
    lab_bushings: bool = typer.Option(
        False,
        "--lab-bushings",
        help="Road test with the bushing networks of the lab record instead of ones trained on a vehicle-derived rig record (the damper networks then too: their drive comes from the same vehicle result).",
    ),
    lab_dampers: bool = typer.Option(
        False,
        "--lab-dampers",
        help="Road test with the damper networks of the lab record instead of ones trained on a vehicle-derived dyno record.",
    ),
) -> None:
    """Run the pipeline end to end on built-in data: rig data, networks, ONNX, FMUs, replay, road test, loop."""
    from rich.console import Console

    from nnfmu.workflows.demo_start import demo_started

    console = Console(markup=False)  # diagnosis test names carry brackets: test[velocity]
    # the monolithic kernel starts compiling (first run) on the second core while this process loads its modules
    with _user_errors(), _warnings_as_lines(), demo_started(console.print) as clock:
        with clock.stage("loading modules"):
            from nnfmu.workflows.demo import DemoSettings, run_demo
            from nnfmu.workflows.tables import COMPONENT_LEGEND, component_table, loop_table, stage_table
        summary = run_demo(
            out,
            DemoSettings(seed=seed, quick=quick, vehicle_bushings=not lab_bushings, vehicle_dampers=not lab_dampers),
            clock=clock,
        )
    console.print(component_table(summary.models))
    console.print(COMPONENT_LEGEND)
    console.print(f"component report: {summary.report}")
    for system, report in summary.road_test.items():
        console.print(f"road test {system} report: {report}")
    loop = summary.loop
    console.print(f"closing the loop: {loop.summary}")
    console.print(loop_table(loop.effects_added, loop.error_before, loop.error_after))
    console.print(f"loop report: {summary.out / 'loop' / 'report.html'}")
    console.print(stage_table(summary.stage_seconds, summary.seconds))
    console.print(f"summary: {summary.out / 'summary.json'}")


@app.command()
def build(
    model: Path = typer.Argument(..., help="ONNX file: an nnfmu step graph, or any graph the backends support."),
    out: Optional[str] = typer.Option(
        None,
        "--out",
        "-o",
        help="FMU path (default: exported/ and the ONNX file's name: damper.onnx -> exported/damper.fmu).",
    ),
    backend: str = _backend_option(),
    fmi: int = _fmi_option(),
    name: Optional[str] = typer.Option(None, help="Model name (default: from the ONNX metadata)."),
    filter_cutoff: Optional[float] = typer.Option(
        None,
        help="Start value [Hz] of the FMU's output low-pass (default: the model's, 0 = off; the thesis used 100 "
        "for stability of a stiff coupling, at a large cost in accuracy: docs/fmu.md).",
    ),
    platforms: Optional[list[str]] = _platforms_option(),
) -> None:
    """Build a standalone FMI co-simulation FMU from an ONNX model."""
    from nnfmu.workflows.fmu_build import BuildOptions, build_fmu

    with _user_errors():
        target = None if out is None else check_output_file(out, [model])
        with _warnings_as_lines():
            path = build_fmu(
                model,
                BuildOptions(
                    out=target,
                    backend=backend,
                    fmi_version=fmi,
                    name=name,
                    filter_cutoff=filter_cutoff,
                    platforms=_platforms(platforms),
                ),
            )
    typer.echo(f"FMU: {path}")
    _echo_binaries(path)
    _echo_reference_results(path)


def _echo_binaries(fmu: Path) -> None:
    """Say which platforms' binaries the FMU carries (those left out were named in a warning line)."""
    from nnfmu.workflows.fmu_build import binary_folders

    folders = binary_folders(fmu)
    typer.echo(f"binaries: {', '.join(folders) or 'none'}")


def _echo_reference_results(fmu: Path) -> None:
    """Say where the FMU carries its step graph, whether it carries reference results and how to check them."""
    from nnfmu.workflows.fmu_build import GRAPH_MEMBER, has_reference_results

    typer.echo(f"step graph: {GRAPH_MEMBER} inside the FMU (read by nnfmu loop vehicle; verified by nnfmu check)")

    if has_reference_results(fmu):
        typer.echo(f"reference results: yes (FMI-LS-REF); verify with: nnfmu check {fmu}")
    else:
        typer.echo("reference results: none (the ONNX file carries no reference stimulus)")


@app.command()
def check(
    fmu: Path = typer.Argument(
        ..., help="FMU carrying reference results (FMI-LS-REF, extra/org.fmi-standard.fmi-ls-ref)."
    ),
    tolerance: Optional[float] = typer.Option(
        None, help="Allowed max error of each output as a fraction of its peak (default: the experiment's)."
    ),
) -> None:
    """Replay the reference results an FMU carries with fmpy and report pass/fail per output (exit 1 on failure)."""
    from nnfmu.workflows.fmu_build import check_fmu, report_lines

    with _user_errors():
        report = check_fmu(fmu, tolerance)
    for line in report_lines(report):
        typer.echo(line)
    if not report.passed:
        raise typer.Exit(code=1)


@vehicle_app.command("build")
def vehicle_build(
    model: str = typer.Argument(..., help="quarter-car or full-vehicle."),
    out: str = typer.Option(..., "--out", "-o", help="FMU path to write."),
    params: Optional[Path] = typer.Option(
        None,
        help="Parameter file (TOML, SI units): a full-vehicle file (both models; default: the packaged mid-size sedan) or, for quarter-car, a quarter-car file (one with a quarter_car table, e.g. the packaged midsize_sedan_quarter_car_fl.toml).",
    ),
    reference: Optional[list[str]] = typer.Option(
        None,
        help="Components to model inside the vehicle (linear bushing, spline damper), e.g. damper_fl,bushing_fl_front; the rest are ports.",
    ),
    stabilise: Optional[list[str]] = typer.Option(
        None,
        help="Ports to stabilise with their linear reference over each step (stiff bushings on a light arm), e.g. bushing_fl_front,bushing_fl_rear.",
    ),
    port_derivatives: bool = typer.Option(
        False,
        help="Give each stabilised port P the inputs P_per_<deflection> [N/m or N.m/rad] and P_per_<rate> [N.s/m or N.m.s/rad] with their P_..._given flags, so a master can hand it the component's local stiffness and damping every step (nnfmu cosim does, from the component's directional derivatives; docs/masters.md).",
    ),
    sample_period: float = typer.Option(1e-4, help="Internal sample period [s] of the exact discrete model."),
    fmi: int = _fmi_option(),
    corner: Optional[str] = typer.Option(
        None,
        help="Quarter car only: the corner it stands on, fl, fr, rl or rr; its actuator inputs read that corner's drive channels (default: a quarter-car file's own corner, fl of a full-vehicle file).",
    ),
    backend: str = _backend_option(),
    platforms: Optional[list[str]] = _platforms_option(),
) -> None:
    """Build a vehicle model into a co-simulation FMU with external component ports.

    quarter-car takes a quarter-car file or a full-vehicle file (one corner derived); full-vehicle a full-vehicle file.
    """
    from nnfmu.workflows.fmu_build import VehicleBuildSettings, build_vehicle_fmu

    with _user_errors():
        settings = VehicleBuildSettings(
            params_path=params,
            components={n: "reference" for n in _split(reference)} | {n: "stabilised" for n in _split(stabilise)},
            sample_period=sample_period,
            port_derivatives=port_derivatives,
            fmi_version=fmi,
            corner=corner,
            backend=backend,
            platforms=_platforms(platforms),
        )
        with _warnings_as_lines():
            path = build_vehicle_fmu(model, check_output_file(out, [params] if params else []), settings)
    typer.echo(f"FMU: {path}")
    _echo_binaries(path)


@controller_app.command("build")
def controller_build(
    law: str = typer.Argument(..., help="Control law: skyhook."),
    out: str = typer.Option(..., "--out", "-o", help="FMU path to write."),
    c_sky: float = typer.Option(3000.0, help="Skyhook damping [N.s/m] along the damper's stroke."),
    c_min: float = typer.Option(1000.0, help="Least damping the damper gives [N.s/m] (at --command-min)."),
    c_max: float = typer.Option(4000.0, help="Greatest damping the damper gives [N.s/m] (at --command-max)."),
    epsilon: float = typer.Option(0.01, help="Regularising stroke velocity [m/s] of the law near zero stroke rate."),
    command: str = typer.Option("voltage", help="The damper's command input: voltage [V] (MR) or current [A] (CDC)."),
    command_min: Optional[float] = typer.Option(None, help="Command giving --c-min (default: 0 V, or 0.3 A)."),
    command_max: Optional[float] = typer.Option(None, help="Command giving --c-max (default: 5 V, or 1.8 A)."),
    sample_period: float = typer.Option(1e-3, help="Controller sample period [s]."),
    fmi: int = _fmi_option(),
) -> None:
    """Build a semi-active damper controller into a co-simulation FMU.

    Inputs body_velocity and damper_velocity [m/s] (the quarter car's outputs), output the damper command.
    """
    from nnfmu.workflows.controller import SkyhookSettings, build_controller_fmu, known_command

    with _user_errors():
        settings = SkyhookSettings(
            c_sky=c_sky,
            c_min=c_min,
            c_max=c_max,
            epsilon=epsilon,
            command=known_command(command, command_min, command_max),
            sample_period=sample_period,
        )
        with _warnings_as_lines():
            path = build_controller_fmu(law, settings, check_output_file(out, []), fmi)
    typer.echo(f"FMU: {path}")
    _echo_binaries(path)


@system_app.command("build")
def system_build(
    system: Path = typer.Argument(..., help="System: SystemStructure.ssd, its folder, or an .ssp archive."),
    out: str = typer.Option(..., "--out", "-o", help="FMU path to write (one co-simulation FMU)."),
    fmi: int = typer.Option(
        2,
        "--fmi",
        help="FMI version of the system FMU: 2 or 3 (FMI 3 has no input derivatives: the drive is held over each step); its FMUs may be 2 or 3.",
    ),
    step: float = _step_option("Communication step H [s] the FMU suggests (its default experiment)."),
    inner_step: Optional[float] = typer.Option(
        None, help="Inner step h [s] at which the FMU steps its parts, H a whole multiple of it (default: --step)."
    ),
    scheme: str = typer.Option("gauss-seidel", help="gauss-seidel (one element after another) or jacobi."),
    order: str = typer.Option("vehicle-first", help="Gauss-Seidel order: vehicle-first or components-first."),
    refresh: bool = typer.Option(
        True, help="Give FMUs with feedthrough their inputs at each inner step's end and read their outputs again."
    ),
    extrapolate_drive: bool = typer.Option(
        True,
        "--extrapolate-drive/--hold-drive",
        help="When the outer master sets no input derivatives, extrapolate the drive over each step from its slope "
        "over the step before (second order in H); --hold-drive holds it (first order).",
    ),
    allow_outside: bool = _allow_outside_option(),
    platforms: Optional[list[str]] = _platforms_option(),
) -> None:
    """Build an SSP system into one co-simulation FMU stepping its FMUs with nnfmu's coupling (docs/system-fmu.md).

    Inputs: the vehicle's free actuator inputs (the drive) in SI units; outputs: every Real output as nnfmu cosim
    names its channels; parameters: element.parameter. Binaries for each platform asked whose binary every FMU of
    the system carries (the others named in a warning line).
    """
    from nnfmu.workflows.system_build import CosimSettings, run_system_build

    with _user_errors():
        target = check_output_file(out, [system])
        settings = CosimSettings(scheme=scheme, order=order, refresh=refresh, port_derivatives=False)
        with _warnings_as_lines():
            plan = run_system_build(
                system,
                target,
                step,
                inner_step,
                settings,
                fmi,
                allow_outside,
                extrapolate_drive,
                _platforms(platforms),
            )
    typer.echo(
        f"FMU: {target} ({len(plan.parts)} FMUs stepped at {plan.inner_step:g} s; {len(plan.inputs)} inputs, "
        f"{len(plan.outputs)} outputs, {len(plan.parameters)} parameters)"
    )
    _echo_binaries(target)


@app.command()
def cosim(
    system: Path = typer.Argument(..., help="System: SystemStructure.ssd, its folder, or an .ssp archive."),
    drive: Path = typer.Option(..., help="Drive file with the actuator channels (.csv, .mf4, .rsp, .drv, .tim)."),
    out: str = typer.Option(..., "--out", "-o", help="Result file (.csv or .mf4), units in every channel."),
    step: float = _step_option("Communication step [s]."),
    stop: Optional[float] = typer.Option(None, help="Stop time [s] (default: the end of the drive file)."),
    scheme: str = typer.Option("gauss-seidel", help="gauss-seidel (one element after another) or jacobi."),
    order: str = typer.Option("vehicle-first", help="Gauss-Seidel order: vehicle-first or components-first."),
    extrapolate: bool = typer.Option(True, help="Extrapolate coupling inputs linearly over the step."),
    refresh: bool = typer.Option(
        True,
        help="Give FMUs with feedthrough (vehicles) their inputs at the step end and "
        "read their outputs again (accelerations see the forces there).",
    ),
    iterations: int = typer.Option(0, help="Iterate each step up to N times with get/set FMU state (strong coupling)."),
    master: str = typer.Option(
        "fmpy",
        help="fmpy (this package's master) or libcosim (cross-check: only --scheme "
        "jacobi --no-extrapolate --no-refresh, libcosim's own algorithm; FMI 2 FMUs only).",
    ),
    engine: str = typer.Option(
        "python",
        help="How the fmpy master runs: python (its loop in Python, one-pass schemes in a C inner loop) or compiled "
        "(the system built into one system FMU with the same coupling, inner step = --step [s], kept in the cache "
        "folder, and stepped from C: the same numbers, a whole run 2-6x faster on the full vehicle; the first run "
        "of a system compiles it, a few seconds; one-pass schemes only: no --iterations, no --no-extrapolate; "
        "docs/system-fmu.md).",
    ),
    step_study: bool = typer.Option(
        False,
        "--step-study",
        help="Also run at step/2 and step/4 and print each channel's estimated coupling error (NRMSE, step "
        "halving) and the largest step [s] meeting --target-nrmse; the study goes to OUT with .json as suffix.",
    ),
    target_nrmse: float = typer.Option(
        0.01, help="Step study: the NRMSE (fraction, 0.01 = 1 %) each channel should meet."
    ),
    allow_outside: bool = _allow_outside_option(),
) -> None:
    """Co-simulate a vehicle FMU with component FMUs on a drive file."""
    from rich.progress import Progress

    from nnfmu.workflows.cosim import CosimSettings, CosimWarning, run_cosim, run_step_study, study_lines

    with _user_errors():
        target = check_output_file(out, [system, drive])
        settings = CosimSettings(
            step=step,
            stop_time=stop,
            scheme=scheme,
            order=order,
            refresh=refresh,
            extrapolation="linear" if extrapolate else "none",
            iterations=iterations,
        )
        if step_study:
            if master != "fmpy" or engine != "python":
                raise typer.BadParameter("--step-study runs on --master fmpy --engine python")
            json_path = check_output_file(str(Path(out).with_suffix(".json")), [system, drive, target])
            with _warnings_as_lines(CosimWarning):
                study = run_step_study(system, drive, settings, json_path, target_nrmse, target)
            for line in study_lines(study):
                typer.echo(line)
            typer.echo(f"result at {step:g} s: {out}; study: {json_path}")
            return
        with Progress(transient=True) as bar, _warnings_as_lines(CosimWarning):
            task = bar.add_task("co-simulation", total=None)
            result = run_cosim(
                system,
                drive,
                settings,
                target,
                master=master,
                progress=lambda done, total: bar.update(task, completed=done, total=total),
                allow_outside=allow_outside,
                engine=engine,
            )
    typer.echo(f"{result.steps} steps of {step:g} s; result: {out}")
    if iterations:
        typer.echo(
            f"mean iterations per step {result.mean_iterations:.2f}, unconverged steps {result.unconverged_steps}"
        )


@app.command()
def batch(
    campaign: Path = typer.Argument(..., help="Campaign file (TOML): events, variants, coupling settings, metrics."),
    out: Path = typer.Option(..., "--out", "-o", help="Folder: results.parquet, campaign.json, summary.html, parts/."),
    scheduler: Optional[str] = typer.Option(None, help="Address of an existing Dask scheduler, e.g. tcp://HOST:8786."),
    workers: Optional[int] = typer.Option(
        None, help="LocalCluster worker processes (default: one per core); 0 runs the cases here, one after another."
    ),
    retry_failed: bool = typer.Option(False, help="Run the cases that failed in an earlier run into --out again."),
    reuse_instances: bool = typer.Option(
        True,
        help="Keep FMU instances between cases and reset them (fmi2Reset/fmi3Reset) instead of opening them again; --no-reuse-instances for FMUs whose reset is unreliable.",
    ),
    allow_outside: bool = _allow_outside_option(),
) -> None:
    """Run a road-test campaign (events x variants) on Dask into one Parquet table of pseudo-damage per channel."""
    from nnfmu.workflows.campaign import run_campaign
    from nnfmu.workflows.campaign.progress import CaseProgress

    if workers is not None and workers < 0:
        raise typer.BadParameter(f"--workers {workers}: give 0 (here, serially) or more")
    with _user_errors():
        run = run_campaign(
            campaign,
            out,
            scheduler=scheduler,
            workers=workers,
            retry_failed=retry_failed,
            reuse_instances=reuse_instances,
            progress=CaseProgress(),
            warn=lambda line: typer.echo(f"warning: {line}", err=True),
            allow_outside=allow_outside,
        )
    typer.echo(
        f"{run.cases} cases: {run.ok} ok, {run.failed} failed, {run.skipped} finished before "
        f"({run.wall_s:.1f} s on {run.engine.kind})"
    )
    typer.echo(f"table: {run.table}\nsummary: {run.summary}\nrecord: {run.record}")


@app.command()
def loop(
    data: Path = typer.Argument(..., help="Measurement (CSV or MDF4) with the model's inputs and the output channel."),
    model: Path = typer.Option(..., help="nnfmu ONNX step graph to check and extend."),
    output: str = typer.Option("force", help="Measured output channel the model predicts."),
    out: Path = typer.Option(
        ..., "--out", "-o", help="Folder for every iteration's ONNX and FMU, report.json and report.html."
    ),
    max_effects: int = typer.Option(3, help="Most effects to add."),
    target_nrmse: Optional[float] = typer.Option(
        None, "--target-nrmse", help="Test-part NRMSE [%] the report's headline judges the final model by; default 5 %."
    ),
) -> None:
    """Replay the model's FMU on measured data, trace the residual to missing physical effects, add them, report."""
    from nnfmu.workflows.loop.run import run_loop
    from nnfmu.workflows.loop.settings import LoopSettings
    from nnfmu.workflows.validation import Target

    with _user_errors():
        target = Target() if target_nrmse is None else Target(target_nrmse / 100, "--target-nrmse")
        with _warnings_as_lines():
            report = run_loop(data, model, output, out, LoopSettings(max_effects=max_effects, target=target))
    typer.echo(report.summary)
    typer.echo(f"effects added: {', '.join(report.effects_added) or 'none'}")
    for key, label, scale in LOOP_ERRORS:
        values = [report.error_before[key], report.error_after[key]]
        typer.echo(f"  {label}: " + " -> ".join("not meaningful" if v is None else f"{scale * v:.4g}" for v in values))
    for note in report.notes:
        typer.echo(f"  note: {note}")
    typer.echo(f"ONNX: {report.onnx}\nFMU: {report.fmu}\nreport: {out / 'report.html'}")


@app.command()
def iterate(
    target: Path = typer.Argument(
        ..., help="Road record to reproduce (CSV with `name [unit]` headers, MDF4 or RPC III): system output channels."
    ),
    system: Path = typer.Option(..., help="SSP system of the virtual car (SystemStructure.ssd, its folder or .ssp)."),
    out: Path = typer.Option(..., "--out", "-o", help="Folder for drive.csv, report.json and report.html."),
    channels: Optional[list[str]] = typer.Option(
        None, help="Target channels to match, comma-separated (default: every target channel the system outputs)."
    ),
    iterations: int = typer.Option(10, help="Most drives played (1 to 100)."),
    gain: float = typer.Option(0.8, help="Gain g of drive_k+1 = drive_k + g H^-1 (target - response_k) [1]."),
    band: str = typer.Option("0.1:100", help="Frequency band LO:HI [Hz] the drive is corrected in."),
    tolerance: str = typer.Option(
        "0.05", help="NRMSE [1] every channel must reach, optionally CHANNEL=NRMSE items after it (0.05,a=0.08)."
    ),
    noise_level: float = typer.Option(0.1, help="RMS post velocity [m/s] of the identification noise."),
    noise_duration: float = typer.Option(60.0, help="Length [s] of the identification noise run."),
    reestimate: int = typer.Option(2, help="Re-estimate the FRF from the noise and the last N iterations (0: never)."),
    stroke_limit: float = typer.Option(0.125, help="Actuator stroke limit: peak |displacement| from rest [m]."),
    velocity_limit: float = typer.Option(2.5, help="Actuator velocity limit [m/s]."),
    acceleration_limit: float = typer.Option(400.0, help="Actuator acceleration limit [m/s^2]."),
    step: float = _step_option("Communication step of the co-simulations [s]."),
    rpc: bool = typer.Option(False, help="Also write the drive as RPC III (drive.drv)."),
    allow_outside: bool = _allow_outside_option(),
) -> None:
    """Iterate a four-poster drive file on the virtual car until its responses match a road record (noise
    identification, regularised inverse FRF, corrections per iteration within the actuator limits)."""
    from nnfmu.workflows.iterate import (
        ActuatorLimits,
        IterateSettings,
        parse_band,
        parse_tolerance,
        run_iterate,
    )

    with _user_errors():
        common, per_channel = parse_tolerance(tolerance)
        settings = IterateSettings(
            channels=tuple(_split(channels)) or None,
            iterations=iterations,
            gain=gain,
            band=parse_band(band),
            tolerance=common,
            tolerances=per_channel,
            noise_level=noise_level,
            noise_duration=noise_duration,
            reestimate=reestimate,
            limits=ActuatorLimits(stroke_limit, velocity_limit, acceleration_limit),
            step=step,
            rpc=rpc,
            allow_outside=allow_outside,
        )
        result = run_iterate(target, system, out, settings, log=typer.echo)
    typer.echo(f"report: {result.files['html']}")


def _float_list(items: Optional[list[str]], option: str) -> Optional[tuple[float, ...]]:
    """Repeated or comma-separated numbers; None when the option is not given."""
    if not items:
        return None
    try:
        return tuple(float(v) for v in _split(items))
    except ValueError:
        raise typer.BadParameter(f"{option}: give numbers, e.g. 0.1,0.5,1.0") from None


@app.command()
def characterise(
    model: Path = typer.Argument(..., help="The damper's or bushing's model: an nnfmu ONNX step graph or FMU."),
    out: Path = typer.Option(
        ..., "--out", "-o", help="Report folder: CSV tables, PNG figures, summary.json and index.html."
    ),
    measured: Optional[Path] = typer.Option(
        None,
        "--measured",
        help="A record holding the same sine tests (a lab schedule's sine series, or a separate characteristic "
        "record): its tables go beside the model's, with the deviation per test point and whether it lies within "
        "the network's own error (its RMS error on its training record's held-out test split).",
    ),
    velocities: Optional[list[str]] = typer.Option(
        None, "--velocities", help="Damper: peak velocities [m/s], comma-separated (default 0.05 to 1.5)."
    ),
    stroke: float = typer.Option(0.025, "--stroke", help="Damper: stroke amplitude [m] of every test."),
    commands: Optional[list[str]] = typer.Option(
        None,
        "--commands",
        help="Semi-active damper: command levels in the command's unit, voltage [V] or current [A] (default: 5 "
        "across its training envelope).",
    ),
    frequencies: Optional[list[str]] = typer.Option(
        None, "--frequencies", help="Bushing: test frequencies [Hz] (default 1,2,5,10,20,50,100)."
    ),
    amplitudes: Optional[list[str]] = typer.Option(
        None,
        "--amplitudes",
        help="Bushing: amplitudes as fractions [1] of each channel's vehicle range (default 0.25,0.5,1).",
    ),
    settle_cycles: Optional[int] = typer.Option(
        None, "--settle-cycles", help="Cycles run before the measured one (default: damper 2, bushing 3)."
    ),
) -> None:
    """Run a damper's characteristic test or a bushing's dynamic-stiffness tests on the model through its FMU."""
    from nnfmu.workflows.characterise import (
        BushingTestSettings,
        CharacteriseSettings,
        DamperTestSettings,
    )
    from nnfmu.workflows.characterise import (
        characterise as run_characterise,
    )

    damper: dict[str, object] = {"stroke": stroke}
    bushing: dict[str, object] = {}
    for key, value, target in (
        ("peak_velocities", _float_list(velocities, "--velocities"), damper),
        ("commands", _float_list(commands, "--commands"), damper),
        ("frequencies", _float_list(frequencies, "--frequencies"), bushing),
        ("amplitude_fractions", _float_list(amplitudes, "--amplitudes"), bushing),
    ):
        if value is not None:
            target[key] = value
    if settle_cycles is not None:
        damper["settle_cycles"] = bushing["settle_cycles"] = settle_cycles
    with _user_errors():
        settings = CharacteriseSettings(DamperTestSettings(**damper), BushingTestSettings(**bushing))  # type: ignore[arg-type]
        report = run_characterise(model, out, measured, settings, log=typer.echo)
    for line in report.lines:
        typer.echo(f"  {line}")
    typer.echo(f"report: {report.index}")


@app.command("loop-vehicle")
def loop_vehicle(
    measured: Path = typer.Argument(
        ..., help="Lab road-test record (CSV or MDF4): vehicle channels with units, any subset."
    ),
    system: Path = typer.Option(..., help="SSP system of the virtual car (SystemStructure.ssd, its folder or .ssp)."),
    drive: Path = typer.Option(..., help="Drive file the four-poster played (actuator displacements)."),
    out: Path = typer.Option(..., "--out", "-o", help="Folder for report.json, report.html, the fixed system."),
    max_effects: int = typer.Option(3, help="Most (component, effect) pairs and sensor offsets to name."),
    model: Optional[list[str]] = typer.Option(
        None,
        help="ELEMENT=ONNX: an element's step graph (default: the one its FMU carries; a given one must be the same "
        "network, checked by digest, unless the FMU records none); repeat.",
    ),
    allow_outside: bool = _allow_outside_option(),
) -> None:
    """`nnfmu loop vehicle`: which component and which effect explain the lab car's difference from the virtual
    car; the component fixed, its FMU swapped in, the vehicle error before and after."""
    from nnfmu.workflows.vehicle_loop import VehicleLoopSettings, run_vehicle_loop

    models = {}
    for item in model or []:
        element, sep, path = item.partition("=")
        if not sep or not element or not path:
            _fail(SettingsError(f"--model {item!r}: give ELEMENT=PATH.onnx"))
        models[element] = Path(path)
    with _user_errors(), _warnings_as_lines():
        report = run_vehicle_loop(
            measured,
            system,
            drive,
            out,
            VehicleLoopSettings(max_effects=max_effects, allow_outside=allow_outside),
            models,
            log=typer.echo,
        )
    typer.echo(report.summary)
    for item in report.iterations:
        typer.echo(f"  {item['component']}: {item['effect']} (p = {item['p_value']:.3g})")
    for name, pair in report.channels.items():
        before, after = pair["before"], pair["after"]
        typer.echo(
            f"  {name}: NRMSE {100 * before.nrmse:.4g} % -> {100 * after.nrmse:.4g} %, mean shift {before.mean_shift:.4g} -> "
            f"{after.mean_shift:.4g}"
        )
    typer.echo(f"system: {report.fixed_system}\nreport: {out / 'report.html'}")
    for line in report.untested:
        typer.echo(f"warning: {line}")


@data_app.command("check")
def data_check(
    path: Path = typer.Argument(..., help="CSV (`name [unit]` headers, `time [s]` first), MDF4 or MTS 793 export."),
    require: Optional[list[str]] = typer.Option(None, "--require", "-r", help="Channel that must be present (repeat)."),
    channel_map: Optional[list[str]] = _map_option(),
) -> None:
    """Load a measurement, convert it to SI units and report its channels, or say exactly what is wrong."""
    from nnfmu.workflows.data_check import check_data_file

    mapping = _channel_map(channel_map)
    with _user_errors():
        m = check_data_file(path, _split(require), mapping)
    typer.echo(f"{path}: {len(m)} samples, sample period {m.sample_period:.6g} s")
    for name in m.names:
        typer.echo(f"  {name} [{m.units[name]}]  min {m[name].min():.6g}  max {m[name].max():.6g}")
    for note in m.notes.values():
        typer.echo(f"  note: {note}")


def _event_fields(spec: str, option: str, names: tuple[str, ...]) -> dict[str, object]:
    """Parse `TIME[:A[:B...]]` into keyword arguments; the last field may be a side (left/right/both)."""
    fields: dict[str, object] = {}
    for name, text in zip(names, spec.split(":")):
        try:
            fields[name] = text if name == "side" else float(text)
        except ValueError:
            raise typer.BadParameter(f"{option} {spec!r}: {name} {text!r} is not a number") from None
    if len(spec.split(":")) > len(names):
        raise typer.BadParameter(f"{option} {spec!r}: at most {len(names)} fields ({':'.join(names)})")
    return fields


@drive_app.command("generate")
def drive_generate(
    out: str = typer.Option(..., "--out", "-o", help="Drive file: .csv, .mf4, or RPC III (.rsp, .drv, .tim)."),
    road_class: str = typer.Option("C", "--class", help="ISO 8608 road class, A (best) to H."),
    speed: float = typer.Option(20.0, help="Vehicle speed [m/s]."),
    duration: float = typer.Option(50.0, help="Length of the drive [s]."),
    sample_rate: float = typer.Option(1000.0, help="Sample rate [Hz]."),
    wheelbase: float = typer.Option(2.8, help="Wheelbase [m]; the rear posts lag by wheelbase / speed."),
    track_width: float = typer.Option(1.6, help="Track width [m], for the left/right coherence."),
    coherence: str = typer.Option("isotropic", help="Left/right tracks: isotropic, independent or identical."),
    highpass: float = typer.Option(0.5, help="Rig controller high-pass cut-off [Hz]; 0 = off."),
    lowpass: float = typer.Option(40.0, help="Rig controller low-pass cut-off [Hz]; 0 = off."),
    seed: int = typer.Option(0, help="Seed of the random road phases."),
    pothole: Optional[list[str]] = typer.Option(None, help="Pothole TIME[:DEPTH:LENGTH:SIDE] [s, m, m] (repeat)."),
    kerb: Optional[list[str]] = typer.Option(
        None, help="Kerb strike TIME[:HEIGHT:RAMP:LENGTH:SIDE] [s, m, m, m] (repeat)."
    ),
    rpc_data_type: str = _rpc_data_type_option(),
) -> None:
    """Write four actuator displacement channels from an ISO 8608 road at a given speed, with optional events."""
    from nnfmu.workflows.drive import DriveSettings, KerbStrike, Pothole, write_generated_drive

    events = [Pothole(**_event_fields(p, "--pothole", ("time", "depth", "length", "side"))) for p in pothole or []]
    events += [
        KerbStrike(**_event_fields(k, "--kerb", ("time", "height", "ramp_length", "length", "side")))
        for k in kerb or []
    ]
    settings = DriveSettings(
        road_class=road_class,
        speed=speed,
        duration=duration,
        sample_rate=sample_rate,
        wheelbase=wheelbase,
        track_width=track_width,
        coherence=coherence,
        highpass=highpass or None,
        lowpass=lowpass or None,
        seed=seed,
        events=tuple(events),
    )
    with _user_errors():
        target = check_output_file(out, [])
        path = write_generated_drive(settings, target, rpc_data_type=rpc_data_type)
    typer.echo(f"drive file: {path}")


@drive_app.command("convert")
def drive_convert(
    source: Path = typer.Argument(..., help="Drive file to read (.csv, .mf4, .rsp, .drv, .tim)."),
    target: str = typer.Argument(..., help="Drive file to write; the format follows the suffix."),
    rpc_data_type: str = _rpc_data_type_option(),
) -> None:
    """Convert a drive file between CSV, MDF4 and RPC III, keeping channel names and units."""
    from nnfmu.workflows.drive import convert_drive

    with _user_errors():
        path = convert_drive(source, check_output_file(target, [source], "TARGET"), rpc_data_type=rpc_data_type)
    typer.echo(f"drive file: {path}")


def _slopes(items: list[str]) -> dict[str, float]:
    slopes = {}
    for item in items:
        key, sep, value = item.partition("=")
        try:
            if not sep or not key.strip():
                raise ValueError
            slopes[key.strip()] = float(value)
        except ValueError:
            raise typer.BadParameter(f"{item!r}: write QUANTITY_OR_CHANNEL=M, e.g. displacement=3") from None
    return slopes


def _window(text: Optional[str]) -> Optional[tuple[float, float]]:
    if text is None:
        return None
    try:
        start, end = (float(v) for v in text.split(","))
    except ValueError:
        raise typer.BadParameter(f"{text!r}: write START,END in seconds, e.g. 30,35") from None
    return start, end


@app.command()
def validate(
    result: Path = typer.Argument(..., help="Result file (CSV with 'name [unit]' headers, or MDF4)."),
    reference: Path = typer.Argument(..., help="Reference file (measurement or baseline simulation)."),
    channels: Optional[list[str]] = typer.Option(
        None,
        "--channels",
        "-c",
        help="Channels to compare (repeat, or comma-separated); default: every channel both files hold.",
    ),
    out: Path = typer.Option(Path("report"), "--out", "-o", help="Report folder (index.html, summary.json, PNGs)."),
    slope: float = typer.Option(
        5.0, "--slope", help="Basquin slope m for the pseudo-damage (5 suits forces and torques)."
    ),
    slope_for: Optional[list[str]] = typer.Option(
        None, "--slope-for", help="Override m per quantity or channel: QUANTITY_OR_CHANNEL=M (repeat)."
    ),
    fmax: float = typer.Option(50.0, "--fmax", help="Upper PSD frequency [Hz]."),
    psd_resolution: float = typer.Option(0.25, "--psd-resolution", help="Welch frequency resolution [Hz]."),
    window_length: float = typer.Option(
        5.0, "--window-length", help="Time-history plot length around the global peak [s]."
    ),
    window: Optional[str] = typer.Option(None, "--window", help="Fixed time-history window START,END [s], e.g. 30,35."),
    target_nrmse: Optional[float] = typer.Option(
        None, "--target-nrmse", help="NRMSE [%] the report's verdict judges each channel by; default 5 %."
    ),
) -> None:
    """Compare a result with a reference: NRMSE, R², peaks, mean shift, RMS, PSD and rainflow pseudo-damage."""
    from nnfmu.workflows.validation import Target, ValidationSettings, validate_files

    with _user_errors():
        settings = ValidationSettings(
            basquin_slope=slope,
            slopes=_slopes(slope_for or []),
            fmax=fmax,
            psd_resolution=psd_resolution,
            window_length=window_length,
            window=_window(window),
        )
        target = Target() if target_nrmse is None else Target(target_nrmse / 100, "--target-nrmse")
        report = validate_files(result, reference, _split(channels) or None, out, settings, target)
    for c in report.comparisons:
        m = c.metrics
        damage = m.not_meaningful.get("pseudo_damage_ratio") or f"{m.pseudo_damage_ratio:.4g}"
        typer.echo(
            f"{c.name} [{c.unit}]: NRMSE {100 * m.nrmse:.4g} %, R2 {m.r2:.4g}, peak error {m.peak_error:+.3g}, "
            f"pseudo-damage ratio {damage} (m = {c.basquin_slope:g})"
        )
    typer.echo(f"verdict: {report.verdict}")
    typer.echo(f"report: {report.index_html}")


if __name__ == "__main__":
    app()
