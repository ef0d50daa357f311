"""`nnfmu loop`: replay the model's FMU on the measured inputs, diagnose the residual on data not used to fit, add
the top effect to the feature spec, retrain (warm-started, and from a fresh start kept when it predicts better),
rebuild the FMU, replay again; until the residual is consistent with noise, no addable effect is significant, or
`max_effects` were added. Then the report.

Every file goes into a staging folder beside `out_dir`, which replaces `out_dir` only when everything succeeded, so
bad input or a failure midway leaves no half-written result.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from nnfmu.atomic import staging_dir
from nnfmu.component import same_period
from nnfmu.cosim import replay_fmu
from nnfmu.data import DataError, Measurement, check_measurement, load_measurement
from nnfmu.diagnosis import Diagnosis, FamilyGains, diagnose
from nnfmu.export import ExportError, export_onnx, read_step_graph
from nnfmu.fmu import BuildOptions, build_fmu
from nnfmu.models.features import FeatureSpec
from nnfmu.models.trained import TrainedModel
from nnfmu.out_paths import check_output_dir, replace_output_dir
from nnfmu.validate import ValidationSettings, channel_metrics
from nnfmu.workflows.characterise.linked import characterise_models
from nnfmu.workflows.loop.blocks import RecordBlocks, part_measurement, plan_blocks
from nnfmu.workflows.loop.errors import LoopError
from nnfmu.workflows.loop.headline import headline
from nnfmu.workflows.loop.report import write_loop_report
from nnfmu.workflows.loop.results import Iteration, LoopReport
from nnfmu.workflows.loop.settings import LoopSettings
from nnfmu.workflows.loop.trials import nrmse, retrain_rivals, trial_group


def _load(data: str | os.PathLike[str] | Measurement) -> Measurement:
    """The measurement itself, or the rig file read (LoopError naming the file for unreadable data)."""
    if isinstance(data, Measurement):
        return data
    try:
        return load_measurement(data)
    except DataError as err:
        raise LoopError(f"cannot read the data: {err}") from None


def _check(m: Measurement, model: TrainedModel, model_path: Path, output: str, settings: LoopSettings) -> None:
    """LoopError naming the file and channel or value when the data cannot drive the model."""
    if output != model.spec.output:
        raise LoopError(f"{model_path}: the model predicts {model.spec.output!r}, not {output!r}")
    absent = [c for c in (*model.spec.channels, output) if c not in m]
    if absent:
        raise LoopError(
            f"{m.source}: channel(s) {', '.join(map(repr, absent))} needed by {model_path.name} (inputs "
            f"{', '.join(model.spec.channels)}, output {output}) are not in the data (it has: {', '.join(m.names)})"
        )
    try:
        check_measurement(m, required=(*model.spec.channels, output), min_samples=2)
    except DataError as err:
        raise LoopError(f"unusable data: {err}") from None
    dt, period = m.sample_period, model.sample_period
    if not same_period(dt, period):
        raise LoopError(
            f"{m.source}: sample period {dt:.9g} s ({1 / dt:.6g} Hz) differs from the {period:.9g} s ({1 / period:.6g} "
            f"Hz) {model_path.name} was trained at; its delay lines and filters count samples, so resample the data "
            f"to {1 / period:.6g} Hz first"
        )


def _errors(predicted: np.ndarray, measured: np.ndarray, rows: np.ndarray, slope: float) -> dict[str, float | None]:
    """nrmse, r2, peak_error and pseudo_damage_ratio of `predicted` on `rows` (None where not meaningful: a test part
    too short for a damage ratio, `nnfmu.validate.meaningful`)."""
    summary = channel_metrics(predicted[rows], measured[rows], slope).error_summary()
    return {k: _number(v) for k, v in summary.items()}


def _number(x: float | None) -> float | None:
    """A JSON-safe float (None for a missing or infinite value)."""
    return None if x is None or not np.isfinite(x) else float(x)


class _Stage:
    """Builds and replays each iteration's model inside the staging folder."""

    def __init__(
        self, staging: Path, out_dir: Path, m: Measurement, blocks: RecordBlocks, settings: LoopSettings, name: str
    ) -> None:
        self.staging, self.out_dir, self.m, self.blocks, self.settings, self.name = (
            staging,
            out_dir,
            m,
            blocks,
            settings,
            name,
        )

    def fmu(self, onnx_path: Path, k: int) -> Path:
        out = self.staging / f"model_{k}.fmu"
        build_fmu(
            onnx_path,
            BuildOptions(out=out, backend=self.settings.backend, fmi_version=self.settings.fmi_version, name=self.name),
        )
        return out

    def replay(self, fmu_path: Path, output: str) -> np.ndarray:
        return np.asarray(replay_fmu(fmu_path, self.m)[output], dtype=float)

    def export(self, model: TrainedModel, k: int, effect: str) -> Path:
        path = self.staging / f"model_{k}.onnx"
        a, b = self.blocks.ranges["test"][0]
        export_onnx(
            model,
            path,
            name=self.name,
            verify_on={c: self.m[c][a:b] for c in model.spec.channels},
            description=f"{model.spec.output} model extended by nnfmu loop with {effect} on {self.m.source}",
        )
        return path

    def final(self, path: Path) -> Path:
        """Where a staged file lies once the staging folder became `out_dir`."""
        return self.out_dir / path.relative_to(self.staging)


def run_loop(
    data: str | os.PathLike[str] | Measurement,
    model_path: str | os.PathLike[str],
    output: str,
    out_dir: str | os.PathLike[str],
    settings: LoopSettings = LoopSettings(),
) -> LoopReport:
    """Close the loop on `data` (a rig file or a Measurement) for the ONNX model at `model_path` predicting `output`;
    write every iteration's ONNX and FMU, report.json, report.html and plots into `out_dir`. LoopError for bad input
    (missing channel, other sample rate, too short a record), OutputPathError for an `out_dir` that holds an input
    or files nnfmu did not write there as a loop result; nothing is written then."""
    model_path = Path(model_path)
    inputs = [model_path] if isinstance(data, Measurement) else [model_path, Path(data)]
    out_dir = check_output_dir(out_dir, "loop", inputs, replaces=True)
    try:
        model, component = read_step_graph(model_path)
    except ExportError as error:
        raise LoopError(f"{error} (the loop extends and retrains models exported by `nnfmu train`)") from None
    m = _load(data)
    _check(m, model, model_path, output, settings)
    blocks = plan_blocks(len(m), settings, m.source)
    rows = {part: blocks.rows(part) for part in ("train", "validation", "diagnosis", "test")}
    fit = np.concatenate([rows["train"], rows["validation"]])
    diagnosis_part = part_measurement(m, rows["diagnosis"], "diagnosis")
    measured = np.asarray(m[output], dtype=float)
    slope = ValidationSettings().slope_for(output)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    with staging_dir(out_dir.parent, f".{out_dir.name}.staging-") as staging:
        stage = _Stage(staging, out_dir, m, blocks, settings, component.name)
        onnx_path = staging / "model_0.onnx"
        shutil.copyfile(model_path, onnx_path)
        fmu_path = stage.fmu(onnx_path, 0)
        predicted = stage.replay(fmu_path, output)
        first_prediction = predicted
        added: list[str] = []
        iterations: list[Iteration] = []
        diagnoses: list[Diagnosis] = []
        notes: list[str] = []
        steps: list[tuple[np.ndarray, FeatureSpec]] = []
        while True:
            d = diagnose(diagnosis_part, predicted[rows["diagnosis"]], output, model.spec.channels, settings.diagnosis)
            diagnoses.append(d)
            if d.consistent_with_noise:
                break
            if len(added) >= settings.max_effects:
                if d.significant:
                    notes.append(
                        f"stopped at max_effects = {settings.max_effects}; still significant: "
                        + ", ".join(e.name for e in d.significant)
                    )
                break
            beyond = FamilyGains(
                diagnosis_part, predicted[rows["diagnosis"]], output, model.spec.channels, settings.diagnosis
            ).explained
            group, partners = trial_group(d, model, m, fit, added, beyond, settings, notes)
            if not group:
                small = [
                    e.name
                    for e in d.significant
                    if e.name not in added and (e.additional_explained_variance or 0.0) < settings.min_explained
                ]
                if small:
                    notes.append(
                        f"significant but below min_explained = {settings.min_explained:.0%} of the residual "
                        f"variance, so not added: {', '.join(small)}"
                    )
                break
            k = len(iterations) + 1
            pick, group, trials, scores = retrain_rivals(group, partners, model, m, rows, fit, settings)
            (ext, evidence, reason), retrained = group[pick], trials[pick]
            new_onnx = stage.export(retrained.model, k, ext.effect)
            new_fmu = stage.fmu(new_onnx, k)
            new_predicted = stage.replay(new_fmu, output)
            before = nrmse(predicted, measured, rows["diagnosis"])
            after = nrmse(new_predicted, measured, rows["diagnosis"])
            accepted = after < before
            iterations.append(
                Iteration(
                    effects=tuple(ext.effect.split("+")),
                    explained_variance=_number(evidence.additional_explained_variance),
                    explained_variance_alone=_number(evidence.explained_variance),
                    p_value=_number(evidence.p_value),
                    extension=ext.note,
                    reason=reason,
                    features_added=ext.added,
                    error_before=_errors(predicted, measured, rows["test"], slope),
                    error_after=_errors(new_predicted, measured, rows["test"], slope),
                    diagnosis_nrmse_before=before,
                    diagnosis_nrmse_after=after,
                    accepted=accepted,
                    onnx=stage.final(new_onnx),
                    fmu=stage.final(new_fmu),
                    extra_hidden=retrained.extra_hidden,
                    start=retrained.start,
                    diagnosis_nrmse_by_start=retrained.diagnosis_nrmse_by_start,
                    trials={g[0].effect: score for g, score in zip(group, scores)},
                )
            )
            steps.append((predicted, ext.spec))
            if not accepted:
                notes.append(
                    f"adding {ext.effect} did not lower the error on the diagnosis part (NRMSE {before:.4g} "
                    f"-> {after:.4g}); it was not kept and the loop stopped"
                )
                break
            added.extend(ext.effect.split("+"))
            model, predicted, onnx_path, fmu_path = retrained.model, new_predicted, new_onnx, new_fmu
        last = diagnoses[-1]
        characterisations = _characterise(staging, fmu_path, settings)
        error_before = _errors(first_prediction, measured, rows["test"], slope)
        error_after = _errors(predicted, measured, rows["test"], slope)
        target = settings.target
        report = LoopReport(
            data=m.source,
            model=str(model_path),
            output=output,
            blocks=blocks.describe(m.time),
            effects_added=added,
            iterations=iterations,
            error_before=error_before,
            error_after=error_after,
            onnx=stage.final(onnx_path),
            fmu=stage.final(fmu_path),
            consistent_with_noise=last.consistent_with_noise,
            summary=headline(output, iterations, last, error_before["nrmse"], error_after["nrmse"], target),
            notes=notes,
            missing_measurements=sorted({note for dg in diagnoses for note in dg.missing_measurements}),
            diagnoses=diagnoses,
            details=_summary(added, last),
            target={"nrmse": target.nrmse, "source": target.source},
            characterisations=characterisations,
        )
        write_loop_report(staging, report, m, rows, first_prediction, predicted, steps)
        replace_output_dir(staging, out_dir, "loop")
    return report


def _characterise(staging: Path, final_fmu: Path, settings: LoopSettings) -> dict[str, dict[str, str | None]]:
    """The first and the final model's FMUs characterised into `staging`/characterise/ (the final one only when
    the loop changed the model): per model the link from report.html, or why it has none."""
    if settings.characterise is None:
        return {}
    first = staging / "model_0.fmu"
    models = {"first": first} | ({"final": final_fmu} if final_fmu != first else {})
    found = characterise_models(models, staging / "characterise", settings.characterise)
    return {label: {"link": c.link(staging / "report.html"), "reason": c.reason} for label, c in found.items()}


def _summary(added: list[str], last: Diagnosis) -> str:
    """The outcome in the diagnosis's terms (effect and test names): the report's details."""
    found = f"added {', '.join(added)}" if added else "added nothing"
    return f"{found}; final diagnosis: {last.summary}"
