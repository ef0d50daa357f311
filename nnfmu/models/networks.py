"""The torch networks nnfmu trains: the thesis's one-hidden-layer tanh perceptron and a GRU for hysteresis.

Both work on min-max scaled features ([-1, 1]) and produce a scaled target; float64 throughout so the exported
graph reproduces them to 1e-9.
"""

from __future__ import annotations

import torch
from torch import nn


class MLP(nn.Module):
    """n_in-hidden-n_out perceptron: tanh hidden layer, linear output (the thesis's networks)."""

    def __init__(self, n_in: int, hidden: int, n_out: int = 1) -> None:
        super().__init__()
        self.hidden = nn.Linear(n_in, hidden, dtype=torch.float64)
        self.out = nn.Linear(hidden, n_out, dtype=torch.float64)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """x: (..., n_in) scaled features -> (..., n_out) scaled target."""
        return self.out(torch.tanh(self.hidden(x)))


class GRUNet(nn.Module):
    """Single-layer GRU with a linear read-out: the recurrent option for hysteresis and memory."""

    def __init__(self, n_in: int, hidden: int, n_out: int = 1) -> None:
        super().__init__()
        self.gru = nn.GRU(n_in, hidden, batch_first=True, dtype=torch.float64)
        self.out = nn.Linear(hidden, n_out, dtype=torch.float64)

    def forward(self, x: torch.Tensor, h0: torch.Tensor | None = None) -> torch.Tensor:
        """x: (batch, time, n_in) scaled features; h0: (1, batch, hidden) or None (zeros) -> (batch, time, n_out)."""
        y, _ = self.gru(x, h0)
        return self.out(y)
