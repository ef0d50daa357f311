"""The `nnfmu train` workflow: load a rig file, train a preset (or custom) network, export and verify the ONNX step
graph, and return everything the CLI prints. The CLI only formats; this module does the work."""

from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Literal

from nnfmu.data import Measurement, load_measurement
from nnfmu.data.band import BAND_POWER_SHARE
from nnfmu.data.errors import DataError
from nnfmu.data.inertia import compensate_inertia
from nnfmu.data.moving_mass import estimate_moving_mass
from nnfmu.errors import SettingsError
from nnfmu.export import ExportResult, export_onnx
from nnfmu.export.metadata import build_component
from nnfmu.export.step_graph import build_step_graph
from nnfmu.models.features import FeatureSpec
from nnfmu.models.metrics import SplitMetrics
from nnfmu.models.networks import GRUNet
from nnfmu.models.presets import COMMAND, Preset, bind_command, custom_spec, get_preset, recurrent
from nnfmu.models.selection import SelectionResult, SelectionSettings, select_inputs
from nnfmu.models.train import (
    Acceptance,
    Architecture,
    Progress,
    SizeTrial,
    TrainResult,
    TrainSettings,
    train_model,
)
from nnfmu.models.trained import TrainedModel
from nnfmu.workflows.passivity import passivity_warnings


@dataclass(frozen=True)
class TrainRequest:
    """What the user asked for. Empty/None fields take the preset's defaults.

    output: output channel; inputs/delays: replace the preset's input taps (delays apply to every input); hidden: one
    size, or several to choose among by validation error; thesis: the thesis's inputs, delays and fixed hidden size
    instead of nnfmu's default (high-pass memory bank, hidden size by validation); recurrent: GRU instead of the MLP;
    select_inputs: choose the inputs by sensitivity analysis (overrides the preset's and `inputs`); optimizer: auto, lm,
    adam or lbfgs; channel_map: (file channel, nnfmu name) pairs passed to `load_measurement`; moving_mass [kg]: the
    dyno's mass between load cell and actuator, subtracted from the force as m·a before training (`nnfmu.data.inertia`;
    0: none; "auto": estimated from the record (`nnfmu.data.moving_mass`) and subtracted where its interval excludes
    0, refused for presets other than the passive dampers'; None: for a passive damper as "auto", a record the
    estimate cannot read trained as measured with a note; other presets nothing subtracted);
    input_cutoff [Hz]: the inputs' zero-phase low-pass before the features (`TrainSettings.input_cutoff`; 0: none;
    None: the preset's).
    """

    preset: str
    output: str | None = None
    inputs: tuple[str, ...] = ()
    delays: tuple[int, ...] = ()
    hidden: tuple[int, ...] = ()
    thesis: bool = False
    recurrent: bool = False
    restarts: int | None = None
    seed: int = 0
    max_epochs: int | None = None
    select_inputs: bool = False
    optimizer: str | None = None
    name: str = ""
    channel_map: tuple[tuple[str, str], ...] = ()
    moving_mass: float | Literal["auto"] | None = None
    input_cutoff: float | None = None


@dataclass
class TrainOutcome:
    """Result of one `train` run: the written model, its metrics per split, export check, input ranking, timing,
    the notes the loader left on the data (time base, channel names, derived rates) and those the training left on
    the feature spec (stop operators left out); `feature_choice` the
    validation MSE (scaled) of each of the preset's candidate feature sets where it offers several (else empty)."""

    path: Path
    model: TrainedModel
    metrics: dict[str, SplitMetrics]
    export: ExportResult
    trials: list[SizeTrial]
    selection: SelectionResult | None
    warnings: list[str]
    seconds: float
    data_notes: list[str]
    training_notes: list[str] = field(default_factory=list)
    feature_choice: list[tuple[FeatureSpec, float]] = field(default_factory=list)


def resolve(request: TrainRequest) -> tuple[Preset, Architecture, TrainSettings]:
    """The preset named by the request with the request's overrides applied to network and training settings."""
    preset = get_preset(request.preset)
    architecture = preset.thesis if request.thesis else preset.architecture
    if request.recurrent:
        architecture = recurrent(architecture, request.hidden)
    elif request.hidden:
        architecture = replace(architecture, hidden=tuple(request.hidden))
    overrides: dict[str, object] = {"seed": request.seed}
    if request.restarts is not None:
        overrides["restarts"] = request.restarts
    if request.max_epochs is not None:
        overrides["max_epochs"] = request.max_epochs
    if request.optimizer is not None:
        overrides["optimizer"] = request.optimizer
    if request.input_cutoff is not None:
        overrides["input_cutoff"] = request.input_cutoff or None
    settings = preset.thesis_settings if request.thesis else preset.settings
    return preset, architecture, replace(settings, **overrides)


def _stage(progress: Progress | None, start: float, end: float) -> Progress | None:
    """A progress callback that maps a stage's own 0..1 onto [start, end] of the whole run."""
    if progress is None:
        return None
    return lambda label, done: progress(label, start + (end - start) * done)


PASSIVE_DAMPERS = ("damper-spline", "damper-hysteresis")  # presets whose force the moving-mass estimate models


def _load(
    data: str | os.PathLike[str], required: list[str], output: str, request: TrainRequest
) -> tuple[Measurement, float, list[str]]:
    """The rig file with the request's channel map, its output compensated for the dyno's moving mass as the request
    says; also the mass taken out [kg] and the warnings about it."""
    required = [c for c in required if c != COMMAND]  # bound to the record's command channel once it is read
    measurement = load_measurement(data, required=required, channel_map=dict(request.channel_map))
    mass = request.moving_mass
    if mass is not None and mass != "auto":
        return (compensate_inertia(measurement, mass, output) if mass else measurement), float(mass), []
    passive = request.preset in PASSIVE_DAMPERS and output == "force"
    if mass == "auto" and not passive:
        raise SettingsError(
            f"--moving-mass auto estimates a passive damper's dyno mass from its force; preset {request.preset!r} "
            f"with output {output!r} is not one ({', '.join(PASSIVE_DAMPERS)} with output 'force'): give the mass "
            f"in kg"
        )
    if not passive:
        return measurement, 0.0, []
    try:
        estimate = estimate_moving_mass(measurement, output)
    except DataError as error:
        if mass == "auto":
            raise
        note = {"moving_mass": f"moving mass not estimated: {error}"}
        return (
            replace(measurement, notes=measurement.notes | note),
            0.0,
            [],
        )
    notes = measurement.notes | {"moving_mass": estimate.describe()}
    measurement = replace(measurement, notes=notes)
    if estimate.found:
        compensated = compensate_inertia(measurement, estimate.mass, output)
        if mass is None:
            default = "; the default for a passive damper's record: --moving-mass 0 trains the force as measured"
            compensated = replace(
                compensated, notes=compensated.notes | {"inertia": compensated.notes["inertia"] + default}
            )
        return compensated, estimate.mass, []
    if mass == "auto":
        return (
            measurement,
            0.0,
            [
                f"--moving-mass auto: the estimate {estimate.mass:.3g} ± {estimate.half_width:.2g} kg does not "
                f"exclude 0 kg; {output} left as measured"
            ],
        )
    return measurement, 0.0, []


def train_from_file(
    data: str | os.PathLike[str], request: TrainRequest, out: str | os.PathLike[str], progress: Progress | None = None
) -> TrainOutcome:
    """Train on the rig file `data` as `request` says, export the verified step graph to `out`, return the outcome.

    Raises nnfmu.data.DataError for bad data, SettingsError for a bad request, ExportError if the graph does not
    reproduce the torch model; nothing is written to `out` then.
    """
    started = time.perf_counter()
    preset, architecture, settings = resolve(request)
    spec = custom_spec(
        preset.thesis_spec if request.thesis else preset.spec, request.output, request.inputs, request.delays
    )
    selection = None
    if request.select_inputs:
        measurement, mass, mass_warnings = _load(data, [spec.output], spec.output, request)
        selection_settings = SelectionSettings(training=replace(settings, restarts=min(settings.restarts, 2)))
        selection = select_inputs(measurement, spec.output, selection_settings, _stage(progress, 0.0, 0.5))
        spec = selection.spec
        progress = _stage(progress, 0.5, 1.0)
    else:
        measurement, mass, mass_warnings = _load(data, [*spec.channels, spec.output], spec.output, request)
    spec = bind_command(spec, measurement.channels, str(data))
    compensated = f" ({spec.output} compensated for {mass:g} kg of moving mass)" if mass else ""
    candidates = [spec]
    if (
        preset.variants
        and architecture.kind == "mlp"
        and not (request.thesis or request.inputs or request.delays or request.select_inputs)
    ):
        candidates += [
            bind_command(custom_spec(v, request.output), measurement.channels, str(data)) for v in preset.variants
        ]
    # A bushing network that gives energy back yields to the search's next best that does not (docs/passivity.md)
    accept = partial(passivity_refusals, preset.name)
    spec, result, feature_choice = _fit_candidates(measurement, candidates, architecture, settings, progress, accept)
    block = max(result.splits.test, key=lambda part: part.stop - part.start)
    test = measurement.slice(block.start, block.stop)
    export = export_onnx(
        result.model,
        out,
        name=request.name or preset.name.replace("-", "_"),
        description=f"{network_description(preset, result.model)}; trained by nnfmu on {Path(data).name}{compensated}",
        verify_on={c: test[c] for c in spec.channels},
    )
    metrics = {name: SplitMetrics(**values) for name, values in result.model.metrics.items()}
    return TrainOutcome(
        path=Path(out),
        model=result.model,
        metrics=metrics,
        export=export,
        trials=result.trials,
        selection=selection,
        warnings=[*mass_warnings, *result.warnings],
        seconds=time.perf_counter() - started,
        data_notes=list(measurement.notes.values()),
        training_notes=result.notes,
        feature_choice=feature_choice,
    )


def trained_range(model: TrainedModel) -> str:
    """Where the network answers from its data, per input: the range and the frequency band its record held (beyond
    either it extrapolates; the FMU flags the range, `nnfmu characterise` and `nnfmu cosim` the band)."""
    parts = []
    for channel in model.spec.channels:
        lo, hi = model.envelope[channel]
        band = model.band.get(channel)
        up_to = f" up to {band:.3g} Hz" if band is not None else ""
        parts.append(f"{channel} {lo:.4g} to {hi:.4g} {model.units[channel]}{up_to}")
    return (
        f"trained on {'; '.join(parts)} (up to: {BAND_POWER_SHARE:.0%} of the input's power below); beyond, the "
        "network extrapolates"
    )


def passivity_refusals(name: str, model: TrainedModel) -> list[str]:
    """`passivity_warnings` of a trained model's step graph, built in memory (nothing written): what `nnfmu train`
    asks before it keeps a network (`train_model`'s `accept`)."""
    graph = build_step_graph(model, name, f"{name}: passivity check")
    build_component(model, name, f"{name}: passivity check").attach_to(graph)
    return passivity_warnings(name, graph)


def network_description(preset: Preset, model: TrainedModel) -> str:
    """What the model is and its real layout, e.g. `damper force with hysteresis ... history: 4-12-1 tanh MLP`: the
    preset's words without the thesis's layout it names (`(thesis 2-5-1 ...)`), which the trained network need not
    have."""
    what = re.sub(r"\s*\(thesis [^)]*\)", "", preset.description)
    network = model.network
    if isinstance(network, GRUNet):
        layout = f"{network.gru.input_size}-{network.gru.hidden_size}-{network.out.out_features} GRU"
    else:
        layout = f"{network.hidden.in_features}-{network.hidden.out_features}-{network.out.out_features} tanh MLP"
    return f"{what}: {layout}"


def _fit_candidates(
    measurement: Measurement,
    candidates: list[FeatureSpec],
    architecture: Architecture,
    settings: TrainSettings,
    progress: Progress | None,
    accept: Acceptance,
) -> tuple[FeatureSpec, TrainResult, list[tuple[FeatureSpec, float]]]:
    """Train on every candidate feature set; keep the one whose chosen network has the lowest validation MSE (the
    first on a tie). Returns it, its result and each candidate's validation MSE (empty for a single candidate)."""
    best: tuple[float, FeatureSpec, TrainResult] | None = None
    scores: list[tuple[FeatureSpec, float]] = []
    for i, candidate in enumerate(candidates):
        stage = _stage(progress, i / len(candidates), (i + 1) / len(candidates))
        result = train_model(measurement, candidate, architecture, settings, stage, accept)
        mse = min(t.validation_mse for t in result.trials)
        scores.append((candidate, mse))
        if best is None or mse < best[0]:
            best = (mse, candidate, result)
    assert best is not None
    return best[1], best[2], scores if len(candidates) > 1 else []
