"""Levenberg–Marquardt training of the one-hidden-layer perceptron, as the thesis (MATLAB's trainlm) did.

Each epoch solves the damped Gauss–Newton system (JᵀJ + mu·I) δ = Jᵀr for all weights at once, with the Jacobian
J of the residuals r written out by hand for tanh-hidden/linear-output nets (exact, and far faster than autograd per
sample). mu shrinks tenfold after a step that lowers the training loss and grows tenfold until one does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import torch
from torch.nn.utils import parameters_to_vector, vector_to_parameters

from nnfmu.models.networks import MLP
from nnfmu.models.stopping import FitHistory, TrainingLog
from nnfmu.stopping import check_stop


@dataclass(frozen=True)
class LMSettings:
    """Levenberg–Marquardt settings; mu values as MATLAB's trainlm, patience counted in epochs."""

    max_epochs: int = 500
    patience: int = 12
    mu: float = 1e-3
    mu_decrease: float = 0.1
    mu_increase: float = 10.0
    mu_max: float = 1e10
    min_gradient: float = 1e-10


def mlp_jacobian(network: MLP, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Output (n,) and its Jacobian (n, n_weights) w.r.t. `parameters_to_vector(network.parameters())`.

    x: (n, n_in). Parameter order is hidden.weight (row-major), hidden.bias, out.weight, out.bias.
    """
    w1, b1 = network.hidden.weight, network.hidden.bias
    w2, b2 = network.out.weight, network.out.bias
    if w2.shape[0] != 1:
        raise ValueError(f"Levenberg–Marquardt here fits one output; the network has {w2.shape[0]}")
    with torch.no_grad():
        h = torch.tanh(x @ w1.T + b1)  # (n, H)
        y = h @ w2[0] + b2[0]
        g = w2[0] * (1.0 - h * h)  # d y / d (hidden pre-activation)
        n = x.shape[0]
        jacobian = torch.cat(
            [(g[:, :, None] * x[:, None, :]).reshape(n, -1), g, h, torch.ones(n, 1, dtype=x.dtype)], dim=1
        )
    return y, jacobian


def _mse(network: MLP, x: torch.Tensor, y: torch.Tensor) -> float:
    with torch.no_grad():
        return float(torch.mean((network(x)[:, 0] - y) ** 2))


def fit_lm(
    network: MLP,
    train: tuple[torch.Tensor, torch.Tensor],
    validation: tuple[torch.Tensor, torch.Tensor],
    settings: LMSettings = LMSettings(),
    on_epoch: Callable[[int, int], None] | None = None,
) -> FitHistory:
    """Train `network` in place on scaled (x (n, n_in), y (n,)) pairs; it ends with the best validation epoch's weights.

    `on_epoch(epoch, max_epochs)` is called after every epoch (for progress display).
    """
    x, y = train
    x_val, y_val = validation
    log = TrainingLog(network, settings.patience, _mse(network, x, y), _mse(network, x_val, y_val))
    params = list(network.parameters())
    mu = settings.mu
    reason = "max_epochs"
    for epoch in range(1, settings.max_epochs + 1):
        check_stop()
        weights = parameters_to_vector(params).detach()
        output, jacobian = mlp_jacobian(network, x)
        residual = output - y
        gradient = jacobian.T @ residual
        if float(gradient.abs().max()) < settings.min_gradient * len(y):
            reason = "min_gradient"
            break
        hessian = jacobian.T @ jacobian
        eye = torch.eye(len(weights), dtype=weights.dtype)
        improved = False
        while mu <= settings.mu_max:
            step = torch.linalg.solve(hessian + mu * eye, gradient)
            vector_to_parameters(weights - step, params)
            loss = _mse(network, x, y)
            if math.isfinite(loss) and loss < log.train_loss[-1]:
                mu = max(mu * settings.mu_decrease, 1e-20)
                improved = True
                break
            mu *= settings.mu_increase
        if not improved:
            vector_to_parameters(weights, params)
            reason = "mu_max"
            break
        stop = log.record(epoch, loss, _mse(network, x_val, y_val))
        if on_epoch is not None:
            on_epoch(epoch, settings.max_epochs)
        if stop:
            reason = "validation"
            break
    return log.finish(reason)
