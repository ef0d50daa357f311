"""What `nnfmu loop` found: each iteration (the effect added, its evidence, the errors before and after, the files)
and the whole run, as JSON-safe data. Their own module, so the driver (`run`) and the report writer (`report`)
both import them without importing each other."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nnfmu.diagnosis import Diagnosis
from nnfmu.workflows.loop.trials import TRIAL_TIE


@dataclass
class Iteration:
    """One added effect: its diagnosis evidence, the extension, the test errors before and after, the files."""

    effects: tuple[str, ...]
    explained_variance: float | None
    explained_variance_alone: float | None
    p_value: float | None
    extension: str
    reason: str
    features_added: tuple[str, ...]
    error_before: dict[str, float | None]
    error_after: dict[str, float | None]
    diagnosis_nrmse_before: float
    diagnosis_nrmse_after: float
    accepted: bool
    onnx: Path
    fmu: Path
    extra_hidden: int
    start: str
    diagnosis_nrmse_by_start: dict[str, float]
    trials: dict[str, float] = field(default_factory=dict)

    @property
    def effect(self) -> str:
        """The effect added, or the effects added together joined by '+'."""
        return "+".join(self.effects)

    def to_dict(self) -> dict[str, Any]:
        return {
            "effect": self.effect,
            "effects": list(self.effects),
            "explained_variance": self.explained_variance,
            "explained_variance_alone": self.explained_variance_alone,
            "p_value": self.p_value,
            "extension": self.extension,
            "reason": self.reason,
            "features_added": list(self.features_added),
            "error_before": self.error_before,
            "error_after": self.error_after,
            "diagnosis_nrmse_before": self.diagnosis_nrmse_before,
            "diagnosis_nrmse_after": self.diagnosis_nrmse_after,
            "accepted": self.accepted,
            "onnx": str(self.onnx),
            "fmu": str(self.fmu),
            "extra_hidden_units": self.extra_hidden,
            "retrained_from": f"{self.start} start",
            "diagnosis_nrmse_by_start": dict(self.diagnosis_nrmse_by_start),
            "trials": dict(self.trials),
            "trials_note": (
                "diagnosis-part NRMSE of the network retrained with each rival explanation; the lowest "
                f"won, or the simplest within {TRIAL_TIE:.0%} of it; the winner was also retrained "
                f"together with the effect it beat or the next significant one, and both were added when "
                f"that came more than {TRIAL_TIE:.0%} lower"
            ),
        }


@dataclass
class LoopReport:
    """The whole loop: effects added in order, every iteration, the overall test error before and after, the final
    model's files, the diagnoses (first and last) and notes (effects that could not be added, and why). `summary`:
    the headline in an engineer's words with its verdict against the target NRMSE (`target`: value [1] and source);
    `details`: the same outcome in the diagnosis's terms (effect and test names); `characterisations`: per model
    ("first", "final") the link to its characterisation report relative to the loop's folder, or why it has none."""

    data: str
    model: str
    output: str
    blocks: dict[str, list[list[float]]]
    effects_added: list[str]
    iterations: list[Iteration]
    error_before: dict[str, float | None]
    error_after: dict[str, float | None]
    onnx: Path
    fmu: Path
    consistent_with_noise: bool
    summary: str
    notes: list[str]
    missing_measurements: list[str]
    diagnoses: list[Diagnosis] = field(default_factory=list)
    details: str = ""
    target: dict[str, Any] = field(default_factory=dict)
    characterisations: dict[str, dict[str, str | None]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "data": self.data,
            "model": self.model,
            "output": self.output,
            "blocks": self.blocks,
            "blocks_note": (
                "each segment of the record is cut in time order into train and validation (fit), diagnosis and test; "
                "the diagnosis runs on the diagnosis part and every error is on the test part, never fitted on"
            ),
            "effects_added": list(self.effects_added),
            "iterations": [it.to_dict() for it in self.iterations],
            "error_before": self.error_before,
            "error_after": self.error_after,
            "onnx": str(self.onnx),
            "fmu": str(self.fmu),
            "consistent_with_noise": self.consistent_with_noise,
            "summary": self.summary,
            "target": dict(self.target),
            "details": self.details,
            "notes": list(self.notes),
            "missing_measurements": list(self.missing_measurements),
            "diagnoses": [d.to_dict() for d in self.diagnoses],
            "characterisations": self.characterisations,
        }
