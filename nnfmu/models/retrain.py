"""Retrain a model on an extended feature spec (the loop's step after naming an effect). The warm start goes on from
where the model stands: the old hidden units keep their weights, the new input columns start at zero weight (so
training starts from the old model's output exactly), a few extra hidden units may join with zero output weight.
The fresh start draws a network of the same size at random, as a first fit does, which can leave the old network's
basin. Levenberg-Marquardt trains on the fit part only, early stopping on its validation rows.

Scaling: the old feature columns keep their scalers (the copied weights were learnt on them); the new columns are
min-max scaled with the fit part's extremes. The target keeps its scaler.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

from nnfmu.data import Measurement
from nnfmu.data.denoise import lowpass_channels
from nnfmu.errors import SettingsError
from nnfmu.models.cores import SpareCores, usable_cores
from nnfmu.models.features import FeatureSpec
from nnfmu.models.lm import LMSettings, check_input_coordinates, fit_lm
from nnfmu.models.metrics import max_abs_weight, split_metrics
from nnfmu.models.networks import MLP
from nnfmu.models.scaling import MinMaxScaler
from nnfmu.models.stopping import FitHistory
from nnfmu.models.trained import TrainedModel, trained_model

# Training settings of the first fit that no longer describe the retrained network.
FIRST_FIT_KEYS = ("best_epoch", "epochs_run", "stop_reason", "validation_mse_by_hidden", "samples", "hidden_candidates")
EXTRA_WEIGHT_SCALE = 0.5  # std of the input weights and biases of added hidden units (scaled inputs lie in [-1, 1])


@dataclass(frozen=True)
class RetrainSettings:
    """Levenberg-Marquardt's `max_epochs` and `patience`; `lm_max_samples` (evenly strided training rows it fits on,
    and validation rows it checks on); `lm_mu`, the warm start's initial damping; `extra_hidden`, hidden-unit counts
    the warm start adds beside the copied units, in rising order; `seed` of the added units and the fresh draw;
    `lm_inputs`, the input coordinates its steps are taken in (`nnfmu.models.lm`), whatever the first fit's."""

    max_epochs: int = 1000
    patience: int = 12
    lm_max_samples: int = 20000
    lm_mu: float = 1.0
    extra_hidden: tuple[int, ...] = (0,)
    seed: int = 0
    lm_inputs: str = "raw"

    def __post_init__(self) -> None:
        check_input_coordinates("lm_inputs", self.lm_inputs)
        if self.max_epochs < 1 or self.patience < 1 or self.lm_max_samples < 1:
            raise SettingsError(
                f"max_epochs, patience and lm_max_samples must be >= 1, got {self.max_epochs}, "
                f"{self.patience} and {self.lm_max_samples}"
            )
        if (
            not self.extra_hidden
            or self.extra_hidden[0] < 0
            or any(a >= b for a, b in zip(self.extra_hidden, self.extra_hidden[1:]))
        ):
            raise SettingsError(
                f"extra_hidden must be non-negative unit counts in rising order, got {self.extra_hidden!r}"
            )
        if not (math.isfinite(self.lm_mu) and self.lm_mu > 0):
            raise SettingsError(f"lm_mu must be a positive damping, got {self.lm_mu!r}")


@dataclass(frozen=True)
class Retrained:
    """The retrained model; `start`: "warm" or "fresh"; its hidden units beyond the old network's; each warm
    candidate's best validation MSE (scaled) by extra units (the fresh start's under its own extra count); the
    diagnosis-part NRMSE of each start tried, once judged."""

    model: TrainedModel
    start: str
    extra_hidden: int
    validation_mse: dict[int, float]
    epochs: int
    diagnosis_nrmse_by_start: dict[str, float] = field(default_factory=dict)


def _extended_scaler(old: TrainedModel, spec: FeatureSpec, features: np.ndarray, train: np.ndarray) -> MinMaxScaler:
    """Old columns keep their extremes; new columns get the training rows' extremes."""
    position = {name: i for i, name in enumerate(old.spec.feature_names)}
    lo = np.empty(spec.n_features)
    hi = np.empty(spec.n_features)
    for j, name in enumerate(spec.feature_names):
        if name in position:
            lo[j], hi[j] = old.feature_scaler.lo[position[name]], old.feature_scaler.hi[position[name]]
        else:
            lo[j], hi[j] = np.min(features[train, j]), np.max(features[train, j])
    return MinMaxScaler(lo=lo, hi=hi)


def _warm_network(old: TrainedModel, spec: FeatureSpec, extra: int, seed: int) -> MLP:
    """An MLP over `spec`'s features that computes exactly what `old` does: copied units, zero new weights."""
    source = old.network
    assert isinstance(source, MLP)
    hidden = source.hidden.out_features
    network = MLP(spec.n_features, hidden + extra)
    position = {name: i for i, name in enumerate(old.spec.feature_names)}
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        w1 = torch.zeros(hidden + extra, spec.n_features, dtype=torch.float64)
        for j, name in enumerate(spec.feature_names):
            if name in position:
                w1[:hidden, j] = source.hidden.weight[:, position[name]]
        b1 = torch.zeros(hidden + extra, dtype=torch.float64)
        b1[:hidden] = source.hidden.bias
        if extra:
            w1[hidden:] = EXTRA_WEIGHT_SCALE * torch.randn(
                extra, spec.n_features, generator=generator, dtype=torch.float64
            )
            b1[hidden:] = EXTRA_WEIGHT_SCALE * torch.randn(extra, generator=generator, dtype=torch.float64)
        w2 = torch.zeros(1, hidden + extra, dtype=torch.float64)
        w2[:, :hidden] = source.out.weight
        network.hidden.weight.copy_(w1)
        network.hidden.bias.copy_(b1)
        network.out.weight.copy_(w2)
        network.out.bias.copy_(source.out.bias)
    return network


@dataclass(frozen=True)
class _Problem:
    """The scaled training problem of one extended spec: all rows' features and target, the scaler, and the strided
    training and validation rows LM works on."""

    spec: FeatureSpec
    target: np.ndarray
    scaler: MinMaxScaler
    x: torch.Tensor
    y: torch.Tensor
    train: torch.Tensor
    validation: torch.Tensor

    def fit(self, network: MLP, settings: RetrainSettings, mu: float) -> FitHistory:
        """Levenberg-Marquardt on the training rows from `network`'s weights, early stopping on the validation rows."""
        lm = LMSettings(max_epochs=settings.max_epochs, patience=settings.patience, mu=mu, inputs=settings.lm_inputs)
        train, validation = (self.x[self.train], self.y[self.train]), (self.x[self.validation], self.y[self.validation])
        with SpareCores(usable_cores()) as spare, spare.occupied():  # a lone fit: a second core takes half of JᵀJ
            return fit_lm(network, train, validation, lm, lend=spare.lend)


def _problem(
    old: TrainedModel,
    spec: FeatureSpec,
    m: Measurement,
    train: np.ndarray,
    validation: np.ndarray,
    settings: RetrainSettings,
) -> _Problem:
    """`spec`'s features over the whole record (its inputs low-passed as the first fit's were), scaled as
    `_extended_scaler` says, with the rows LM may use."""
    inputs = lowpass_channels(m, spec.channels, old.settings.get("input_cutoff"))
    features = spec.features({c: inputs[c] for c in spec.channels}, old.sample_period)
    target = np.asarray(m[spec.output], dtype=float)
    scaler = _extended_scaler(old, spec, features, train)
    index_train, index_validation = (
        torch.from_numpy(rows[:: max(1, math.ceil(len(rows) / settings.lm_max_samples))])
        for rows in (train, validation)
    )
    return _Problem(
        spec,
        target,
        scaler,
        torch.from_numpy(scaler.scale(features)),
        torch.from_numpy(old.target_scaler.scale(target)),
        index_train,
        index_validation,
    )


def warm_start(
    old: TrainedModel,
    spec: FeatureSpec,
    m: Measurement,
    train: np.ndarray,
    validation: np.ndarray,
    settings: RetrainSettings,
    effect: str,
) -> Retrained:
    """Retrain `old` on `spec` (an extension of its spec) over rows `train`, early stopping on rows `validation`;
    the extra hidden-unit counts of `settings.extra_hidden` are tried in rising order while each lowers the best
    validation MSE so far, and the lowest kept."""
    problem = _problem(old, spec, m, train, validation, settings)
    best: tuple[float, int, MLP, int] | None = None
    scores: dict[int, float] = {}
    for extra in settings.extra_hidden:
        network = _warm_network(old, spec, extra, settings.seed + extra)
        history = problem.fit(network, settings, settings.lm_mu)
        scores[extra] = history.best_validation_loss
        if best is not None and history.best_validation_loss >= best[0]:
            break  # more units did not help: larger counts would only cost time
        best = (history.best_validation_loss, extra, network, len(history.train_loss) - 1)
    assert best is not None
    _, extra, network, epochs = best
    return _retrained(old, problem, network, m, train, validation, effect, "warm", scores, epochs, settings)


def fresh_start(
    old: TrainedModel,
    spec: FeatureSpec,
    m: Measurement,
    train: np.ndarray,
    validation: np.ndarray,
    settings: RetrainSettings,
    effect: str,
    hidden: int,
) -> Retrained:
    """A network of `hidden` units on `spec` drawn at random under `settings.seed` (torch's default initialisation,
    as the first fit draws its restarts) and trained like a first fit (LM from trainlm's damping), with `old`'s
    scalers for the columns it had."""
    problem = _problem(old, spec, m, train, validation, settings)
    torch.manual_seed(settings.seed)
    network = MLP(spec.n_features, hidden)
    history = problem.fit(network, settings, LMSettings().mu)
    extra = hidden - _hidden(old)
    return _retrained(
        old,
        problem,
        network,
        m,
        train,
        validation,
        effect,
        "fresh",
        {extra: history.best_validation_loss},
        len(history.train_loss) - 1,
        settings,
    )


def retrain(
    old: TrainedModel,
    spec: FeatureSpec,
    m: Measurement,
    train: np.ndarray,
    validation: np.ndarray,
    settings: RetrainSettings,
    label: str,
    start: str = "warm",
    hidden: int | None = None,
) -> Retrained:
    """Retrain `old` on `spec` from where it stands (`start` "warm") or from a random draw of `hidden` units
    ("fresh"); `label` names what was added (recorded in the model's training settings)."""
    if start == "warm":
        return warm_start(old, spec, m, train, validation, settings, label)
    if start == "fresh":
        return fresh_start(old, spec, m, train, validation, settings, label, hidden or _hidden(old))
    raise SettingsError(f"start must be 'warm' or 'fresh', got {start!r}")


def _hidden(model: TrainedModel) -> int:
    """Hidden units of a model's one-hidden-layer network (the loop extends MLPs only)."""
    network = model.network
    assert isinstance(network, MLP)
    return network.hidden.out_features


def _retrained(
    old: TrainedModel,
    problem: _Problem,
    network: MLP,
    m: Measurement,
    train: np.ndarray,
    validation: np.ndarray,
    effect: str,
    start: str,
    scores: dict[int, float],
    epochs: int,
    settings: RetrainSettings,
) -> Retrained:
    """`network` packaged as the extended model, with its metrics and the loop's record of how it was trained."""
    spec, target = problem.spec, problem.target
    extra = network.hidden.out_features - _hidden(old)
    network.eval()
    with torch.no_grad():
        output = old.target_scaler.unscale(network(problem.x)[:, 0].numpy())
    largest = max_abs_weight(network)
    metrics = {
        name: split_metrics(output[rows], target[rows], old.target_scaler, largest).as_dict()
        for name, rows in (("train", train), ("validation", validation))
    }
    model = trained_model(
        spec,
        network,
        problem.scaler,
        old.target_scaler,
        m,
        train,
        old.sample_period,
        metrics,
        {
            **{k: v for k, v in old.settings.items() if k not in FIRST_FIT_KEYS},
            "hidden": network.hidden.out_features,
            "optimizer_used": "lm",
            "source": m.source,
            "retraining": {
                "effect": effect,
                "start": start,
                "old_hidden": _hidden(old),
                "extra_hidden": extra,
                "validation_mse_by_extra_hidden": {str(k): v for k, v in scores.items()},
                "epochs_run": epochs,
                "max_epochs": settings.max_epochs,
                "lm_inputs": settings.lm_inputs,
                "samples": {"train": int(len(train)), "validation": int(len(validation))},
            },
        },
        old.envelope,
        old.band,
    )
    return Retrained(model=model, start=start, extra_hidden=extra, validation_mse=scores, epochs=epochs)
