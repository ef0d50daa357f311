"""Early stopping on the validation split: keep the weights of the best validation epoch, stop after `patience`
epochs without improvement (the thesis's guard against over-fitting)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch


class EarlyStopping:
    """Tracks validation losses epoch by epoch and holds a copy of the best network's weights."""

    def __init__(self, patience: int) -> None:
        if patience < 1:
            raise ValueError(f"patience must be >= 1 epoch, got {patience}")
        self.patience = patience
        self.best_loss = math.inf
        self.best_epoch = -1
        self.epochs_without_improvement = 0
        self._best_state: dict[str, torch.Tensor] | None = None

    def update(self, epoch: int, validation_loss: float, network: torch.nn.Module) -> bool:
        """Record one epoch's validation loss; True when training should stop (patience exhausted or loss not
        finite)."""
        if not math.isfinite(validation_loss):
            return True
        if validation_loss < self.best_loss:
            self.best_loss = validation_loss
            self.best_epoch = epoch
            self.epochs_without_improvement = 0
            self._best_state = {name: value.detach().clone() for name, value in network.state_dict().items()}
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

    def __init__(self, network: torch.nn.Module, patience: int, train_loss: float, validation_loss: float) -> None:
        self.network = network
        self.stopper = EarlyStopping(patience)
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
