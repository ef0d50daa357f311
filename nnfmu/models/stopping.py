"""Early stopping on the validation split: keep the weights of the best validation epoch, stop after `patience`
epochs without improvement (the thesis's guard against over-fitting); an improvement that resets the patience may be
required to be at least a relative `min_improvement`, so that a fit creeping down by fractions of a per cent stops."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import torch


class EarlyStopping:
    """Tracks validation losses epoch by epoch and holds a copy of the best network's weights."""

    def __init__(self, patience: int, min_improvement: float = 0.0) -> None:
        if patience < 1:
            raise ValueError(f"patience must be >= 1 epoch, got {patience}")
        if not 0.0 <= min_improvement < 1.0:
            raise ValueError(f"min_improvement must be in [0, 1), got {min_improvement}")
        self.patience = patience
        self.min_improvement = min_improvement
        self.best_loss = math.inf
        self._reference = math.inf  # the loss an improvement must beat by min_improvement to reset the patience
        self.best_epoch = -1
        self.epochs_without_improvement = 0
        self._best_state: dict[str, torch.Tensor] | None = None

    def update(self, epoch: int, validation_loss: float, network: torch.nn.Module) -> bool:
        """Record one epoch's validation loss; True when training should stop (patience exhausted or loss not
        finite). Every new best loss keeps its weights; only one at least `min_improvement` (relative) below the loss
        of the last such improvement resets the patience."""
        if not math.isfinite(validation_loss):
            return True
        if validation_loss < self.best_loss:
            self.best_loss = validation_loss
            self.best_epoch = epoch
            self._best_state = copy.deepcopy(network.state_dict())
        if validation_loss < self._reference * (1.0 - self.min_improvement):
            self._reference = validation_loss
            self.epochs_without_improvement = 0
            return False
        self.epochs_without_improvement += 1
        return self.epochs_without_improvement >= self.patience

    def restore(self, network: torch.nn.Module) -> None:
        """Load the best epoch's weights into `network`."""
        if self._best_state is None:
            raise RuntimeError("no finite validation loss was recorded, so there are no best weights to restore")
        network.load_state_dict(self._best_state)


@dataclass
class FitHistory:
    """Per-epoch losses (epoch 0 = the initial weights), the epoch whose weights were kept, and why training stopped."""

    train_loss: list[float]
    validation_loss: list[float]
    best_epoch: int
    stop_reason: str

    @property
    def best_validation_loss(self) -> float:
        return self.validation_loss[self.best_epoch]


class TrainingLog:
    """The losses of one training run, epoch by epoch, with early stopping on the validation loss.

    Every optimiser (Levenberg–Marquardt, Adam, L-BFGS, the GRU's) records its epochs here, so the stopping rule and
    the history it returns are the same for all of them.
    """

    def __init__(
        self,
        network: torch.nn.Module,
        patience: int,
        train_loss: float,
        validation_loss: float,
        min_improvement: float = 0.0,
    ) -> None:
        self.network = network
        self.stopper = EarlyStopping(patience, min_improvement)
        self.train_loss = [train_loss]
        self.validation_loss = [validation_loss]
        self.stopper.update(0, validation_loss, network)

    def record(self, epoch: int, train_loss: float, validation_loss: float) -> bool:
        """Add one epoch's losses; True when training should stop on the validation loss."""
        self.train_loss.append(train_loss)
        self.validation_loss.append(validation_loss)
        return self.stopper.update(epoch, validation_loss, self.network)

    def finish(self, reason: str) -> FitHistory:
        """Load the best epoch's weights into the network and return the history."""
        self.stopper.restore(self.network)
        return FitHistory(self.train_loss, self.validation_loss, self.stopper.best_epoch, reason)
