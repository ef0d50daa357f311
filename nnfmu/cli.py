"""The `nnfmu` command line: each command parses its options, calls one function and prints the outcome.

Imports of the working stages happen inside the commands, so `nnfmu build` never loads torch.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

app = typer.Typer(no_args_is_help=True, add_completion=False,
                  help="Neural-network component models from rig data, shipped as FMI co-simulation FMUs.")
data_app = typer.Typer(no_args_is_help=True, help="Inspect rig data files.")
app.add_typer(data_app, name="data")
drive_app = typer.Typer(no_args_is_help=True, help="Drive files for a four-post road test simulator.")
app.add_typer(drive_app, name="drive")


def _fail(error: Exception) -> None:
    """Print a user-facing error and exit with status 2."""
    typer.echo(f"error: {error}", err=True)
    raise typer.Exit(code=2)


def _split(items: Optional[list[str]]) -> list[str]:
    """Accept repeated options and comma-separated lists alike."""
    return [n.strip() for item in items or [] for n in item.split(",") if n.strip()]


@app.command()
def rig(
    kind: str = typer.Argument(..., help="Rig to simulate: damper (dyno) or bushing (four-channel rig)."),
    out: Path = typer.Option(..., "--out", "-o", help="Data file (.csv or .mf4); the truth file goes beside it."),
    sample_rate: float = typer.Option(1000.0, help="Sample rate [Hz]."),
    duration: Optional[float] = typer.Option(None, help="Record length [s] (default: damper 70, bushing 60)."),
    seed: int = typer.Option(0, help="Seed for excitation and sensor noise."),
    noise: float = typer.Option(1.0, help="Multiplier of the realistic sensor noise (0: exact values)."),
    effects: Optional[str] = typer.Option(None, help="Comma-separated effects to switch on, or 'none' (default: the kind's defaults)."),
    excitation: str = typer.Option("lab", help="lab (sine series + random), random (held-out test data) or sine."),
) -> None:
    """Simulate a lab rig and write realistic "measured" data plus a separate truth file."""
    from nnfmu.data import DataError
    from nnfmu.data.rigs import RigOptions, write_rig

    chosen = None if effects is None else () if effects.strip() == "none" else tuple(_split([effects]))
    options = RigOptions(sample_rate=sample_rate, duration=duration, seed=seed, noise=noise, effects=chosen,
                         excitation=excitation)
    try:
        data_path, truth_path = write_rig(kind, out, options)
    except (ValueError, DataError) as error:
        _fail(error)
    typer.echo(f"data: {data_path}\ntruth (for evaluation only, never for training): {truth_path}")


@app.command()
def build(
    model: Path = typer.Argument(..., help="ONNX file: an nnfmu step graph, or any graph the backends support."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", help="FMU path (default: exported/NAME.fmu)."),
    backend: str = typer.Option("native", help="native (generated C, no Python at run time) or pythonfmu (onnxruntime)."),
    fmi: int = typer.Option(2, "--fmi", help="FMI version: 2 or 3."),
    name: Optional[str] = typer.Option(None, help="Model name (default: from the ONNX metadata)."),
) -> None:
    """Build a standalone FMI co-simulation FMU from an ONNX model."""
    from nnfmu.fmu.build import build_fmu
    from nnfmu.fmu.errors import FmuBuildError
    from nnfmu.fmu.options import BuildOptions

    try:
        path = build_fmu(model, BuildOptions(out=out, backend=backend, fmi_version=fmi, name=name))
    except FmuBuildError as error:
        _fail(error)
    typer.echo(f"FMU: {path}")


@data_app.command("check")
def data_check(
    path: Path = typer.Argument(..., help="CSV (`name [unit]` headers, `time [s]` first) or MDF4 file."),
    require: Optional[list[str]] = typer.Option(None, "--require", "-r", help="Channel that must be present (repeat)."),
) -> None:
    """Load a measurement, convert it to SI units and report its channels, or say exactly what is wrong."""
    from nnfmu.data import DataError, load_measurement

    try:
        m = load_measurement(path, required=_split(require))
    except DataError as error:
        _fail(error)
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
    out: Path = typer.Option(..., "--out", "-o", help="Drive file: .csv, .mf4, or RPC III (.rsp, .drv, .tim)."),
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
    kerb: Optional[list[str]] = typer.Option(None, help="Kerb strike TIME[:HEIGHT:RAMP:LENGTH:SIDE] [s, m, m, m] (repeat)."),
    rpc_data_type: str = typer.Option("int16", help="RPC III sample type: int16 or float32."),
) -> None:
    """Write four actuator displacement channels from an ISO 8608 road at a given speed, with optional events."""
    from nnfmu.data import DataError
    from nnfmu.vehicle.drive import DriveError, DriveSettings, KerbStrike, Pothole, generate_drive, write_drive

    events = [Pothole(**_event_fields(p, "--pothole", ("time", "depth", "length", "side"))) for p in pothole or []]
    events += [KerbStrike(**_event_fields(k, "--kerb", ("time", "height", "ramp_length", "length", "side")))
               for k in kerb or []]
    settings = DriveSettings(road_class=road_class, speed=speed, duration=duration, sample_rate=sample_rate,
                             wheelbase=wheelbase, track_width=track_width, coherence=coherence,
                             highpass=highpass or None, lowpass=lowpass or None, seed=seed, events=tuple(events))
    try:
        path = write_drive(generate_drive(settings), out, rpc_data_type=rpc_data_type)
    except (DriveError, DataError) as error:
        _fail(error)
    typer.echo(f"drive file: {path}")


@drive_app.command("convert")
def drive_convert(
    source: Path = typer.Argument(..., help="Drive file to read (.csv, .mf4, .rsp, .drv, .tim)."),
    target: Path = typer.Argument(..., help="Drive file to write; the format follows the suffix."),
    rpc_data_type: str = typer.Option("int16", help="RPC III sample type: int16 or float32."),
) -> None:
    """Convert a drive file between CSV, MDF4 and RPC III, keeping channel names and units."""
    from nnfmu.data import DataError
    from nnfmu.vehicle.drive import DriveError, read_drive, write_drive

    try:
        path = write_drive(read_drive(source), target, rpc_data_type=rpc_data_type)
    except (DriveError, DataError) as error:
        _fail(error)
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
    channels: Optional[list[str]] = typer.Option(None, "--channels", "-c", help="Channels to compare (repeat, or comma-separated); default: every channel both files hold."),
    out: Path = typer.Option(Path("report"), "--out", "-o", help="Report folder (index.html, summary.json, PNGs)."),
    slope: float = typer.Option(5.0, "--slope", help="Basquin slope m for the pseudo-damage (5 suits forces and torques)."),
    slope_for: Optional[list[str]] = typer.Option(None, "--slope-for", help="Override m per quantity or channel: QUANTITY_OR_CHANNEL=M (repeat)."),
    fmax: float = typer.Option(50.0, "--fmax", help="Upper PSD frequency [Hz]."),
    psd_resolution: float = typer.Option(0.25, "--psd-resolution", help="Welch frequency resolution [Hz]."),
    window_length: float = typer.Option(5.0, "--window-length", help="Time-history plot length around the global peak [s]."),
    window: Optional[str] = typer.Option(None, "--window", help="Fixed time-history window START,END [s], e.g. 30,35."),
) -> None:
    """Compare a result with a reference: NRMSE, R², peaks, mean shift, RMS, PSD and rainflow pseudo-damage."""
    from nnfmu.validate import ValidationSettings, validate_files

    try:
        settings = ValidationSettings(basquin_slope=slope, slopes=_slopes(slope_for or []), fmax=fmax,
                                      psd_resolution=psd_resolution, window_length=window_length,
                                      window=_window(window))
        report = validate_files(result, reference, _split(channels) or None, out, settings)
    except ValueError as error:  # DataError and bad settings alike
        _fail(error)
    for c in report.comparisons:
        m = c.metrics
        typer.echo(f"{c.name} [{c.unit}]: NRMSE {m.nrmse:.4g}, R2 {m.r2:.4g}, peak error {m.peak_error:+.3g}, "
                   f"pseudo-damage ratio {m.pseudo_damage_ratio:.4g} (m = {c.basquin_slope:g})")
    typer.echo(f"report: {report.index_html}")


if __name__ == "__main__":
    app()
