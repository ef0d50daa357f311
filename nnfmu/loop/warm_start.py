"""Retrain a model on an extended feature spec. The warm start goes on from where the model stands: the old hidden
units keep their weights, the new input columns start at zero weight (so training starts from the old model's output
exactly), a few extra hidden units may join with zero output weight. The fresh start draws a network of the same size
at random, as a first fit does, which can leave the old network's basin. Levenberg-Marquardt trains on the fit part
only, early stopping on its validation rows.

Scaling: the old feature columns keep their scalers (the copied weights were learnt on them); the new columns are
min-max scaled with the fit part's extremes. The target keeps its scaler.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

from nnfmu.data import Measurement
from nnfmu.models.features import FeatureSpec
from nnfmu.models.lm import LMSettings, fit_lm
from nnfmu.models.metrics import max_abs_weight, split_metrics
from nnfmu.models.networks import MLP
from nnfmu.models.scaling import MinMaxScaler
from nnfmu.models.stopping import FitHistory
from nnfmu.models.train import data_hash
from nnfmu.models.trained import TrainedModel

from .loop_settings import LoopSettings

# Training settings of the first fit that no longer describe the retrained network.
FIRST_FIT_KEYS = ("best_epoch", "epochs_run", "stop_reason", "validation_mse_by_hidden", "samples", "hidden_candidates")
EXTRA_WEIGHT_SCALE = 0.5  # std of the input weights and biases of added hidden units (scaled inputs lie in [-1, 1])


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
            w1[hidden:] = EXTRA_WEIGHT_SCALE * torch.randn(extra, spec.n_features, generator=generator,
                                                           dtype=torch.float64)
            b1[hidden:] = EXTRA_WEIGHT_SCALE * torch.randn(extra, generator=generator, dtype=torch.float64)
        w2 = torch.zeros(1, hidden + extra, dtype=torch.float64)
        w2[:, :hidden] = source.out.weight
        network.hidden.weight.copy_(w1)
        network.hidden.bias.copy_(b1)
        network.out.weight.copy_(w2)
        network.out.bias.copy_(source.out.bias)
    return network


def _envelope(old: TrainedModel, spec: FeatureSpec, m: Measurement,
              train: np.ndarray) -> dict[str, tuple[float, float]]:
    """Each input's range over the training rows, widened by the old model's envelope where it had the channel."""
    envelope = {}
    for c in spec.channels:
        lo, hi = float(np.min(m[c][train])), float(np.max(m[c][train]))
        if c in old.envelope:
            lo, hi = min(lo, old.envelope[c][0]), max(hi, old.envelope[c][1])
        envelope[c] = (lo, hi)
    return envelope


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

    def fit(self, network: MLP, settings: LoopSettings, mu: float) -> FitHistory:
        """Levenberg-Marquardt on the training rows from `network`'s weights, early stopping on the validation rows."""
        lm = LMSettings(max_epochs=settings.max_epochs, patience=settings.patience, mu=mu)
        return fit_lm(network, (self.x[self.train], self.y[self.train]),
                      (self.x[self.validation], self.y[self.validation]), lm)


def _problem(old: TrainedModel, spec: FeatureSpec, m: Measurement, train: np.ndarray, validation: np.ndarray,
             settings: LoopSettings) -> _Problem:
    """`spec`'s features over the whole record, scaled as `_extended_scaler` says, with the rows LM may use."""
    features = spec.features({c: m[c] for c in spec.channels}, old.sample_period)
    target = np.asarray(m[spec.output], dtype=float)
    scaler = _extended_scaler(old, spec, features, train)
    index_train, index_validation = (torch.from_numpy(rows[:: max(1, math.ceil(len(rows) / settings.lm_max_samples))])
                                     for rows in (train, validation))
    return _Problem(spec, target, scaler, torch.from_numpy(scaler.scale(features)),
                    torch.from_numpy(old.target_scaler.scale(target)), index_train, index_validation)


def warm_start(
    old: TrainedModel, spec: FeatureSpec, m: Measurement, train: np.ndarray, validation: np.ndarray,
    settings: LoopSettings, effect: str,
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
    old: TrainedModel, spec: FeatureSpec, m: Measurement, train: np.ndarray, validation: np.ndarray,
    settings: LoopSettings, effect: str, hidden: int,
) -> Retrained:
    """A network of `hidden` units on `spec` drawn at random under `settings.seed` (torch's default initialisation,
    as the first fit draws its restarts) and trained like a first fit (LM from trainlm's damping), with `old`'s
    scalers for the columns it had."""
    problem = _problem(old, spec, m, train, validation, settings)
    torch.manual_seed(settings.seed)
    network = MLP(spec.n_features, hidden)
    history = problem.fit(network, settings, LMSettings().mu)
    extra = hidden - _hidden(old)
    return _retrained(old, problem, network, m, train, validation, effect, "fresh",
                      {extra: history.best_validation_loss}, len(history.train_loss) - 1, settings)


def _hidden(model: TrainedModel) -> int:
    """Hidden units of a model's one-hidden-layer network (the loop extends MLPs only)."""
    network = model.network
    assert isinstance(network, MLP)
    return network.hidden.out_features


def _retrained(
    old: TrainedModel, problem: _Problem, network: MLP, m: Measurement, train: np.ndarray, validation: np.ndarray,
    effect: str, start: str, scores: dict[int, float], epochs: int, settings: LoopSettings,
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
    model = TrainedModel(
        spec=spec,
        network=network,
        feature_scaler=problem.scaler,
        target_scaler=old.target_scaler,
        sample_period=old.sample_period,
        units={c: m.units[c] for c in (*spec.channels, spec.output)},
        envelope=_envelope(old, spec, m, train),
        metrics=metrics,
        data_hash=data_hash(m, [*spec.channels, spec.output]),
        settings={
            **{k: v for k, v in old.settings.items() if k not in FIRST_FIT_KEYS},
            "hidden": network.hidden.out_features,
            "optimizer_used": "lm",
            "source": m.source,
            "loop": {
                "effect": effect,
                "start": start,
                "old_hidden": _hidden(old),
                "extra_hidden": extra,
                "validation_mse_by_extra_hidden": {str(k): v for k, v in scores.items()},
                "epochs_run": epochs,
                "max_epochs": settings.max_epochs,
                "samples": {"train": int(len(train)), "validation": int(len(validation))},
            },
        },
    )
    return Retrained(model=model, start=start, extra_hidden=extra, validation_mse=scores, epochs=epochs)
