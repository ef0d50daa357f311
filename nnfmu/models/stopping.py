"""Early stopping on the validation split: keep the weights of the best validation epoch, stop after `patience`
epochs without improvement (the thesis's guard against over-fitting)."""

from __future__ import annotations

import copy
import math

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
        """Record one epoch's validation loss; True when training should stop (patience exhausted or loss not finite)."""
        if not math.isfinite(validation_loss):
            return True
        if validation_loss < self.best_loss:
            self.best_loss = validation_loss
            self.best_epoch = epoch
            self.epochs_without_improvement = 0
            self._best_state = copy.deepcopy(network.state_dict())
            return False
        self.epochs_without_improvement += 1
        return self.epochs_without_improvement >= self.patience

    def restore(self, network: torch.nn.Module) -> None:
        """Load the best epoch's weights into `network`."""
        if self._best_state is None:
            raise RuntimeError("no finite validation loss was recorded, so there are no best weights to restore")
        network.load_state_dict(self._best_state)
