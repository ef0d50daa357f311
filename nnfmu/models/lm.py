"""Levenberg–Marquardt training of the one-hidden-layer perceptron, as the thesis (MATLAB's trainlm) did, in float64.

Each epoch solves a damped Gauss–Newton system (JᵀJ + mu·D) δ = Jᵀr by Cholesky, with the Jacobian J of the
residuals r written out by hand for tanh-hidden/linear-output nets (exact, and far faster than autograd per sample).
mu shrinks tenfold after a step that lowers the training loss and grows tenfold until one does.

By default the fit is separable (variable projection, Golub & Pereyra; Kaufman's Jacobian; Sjöberg & Viberg 1997 for
neural nets): the output layer is linear in its weights, so for every hidden layer it is solved exactly by linear
least squares and LM steps the hidden weights only, on the Jacobian projected off the output layer's basis. On the
damper dyno's record (4-12-1, one seed) it reached in 50 epochs the validation MSE the joint step reached in 200, and
after 100 a lower one than the joint step's after 300.
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

# Called after every epoch: (epoch, max_epochs, training MSE, validation MSE), both scaled.
EpochReport = Callable[[int, int, float, float], None]


@dataclass(frozen=True)
class LMSettings:
    """Levenberg–Marquardt settings; mu values as MATLAB's trainlm, patience counted in epochs.

    separable: solve the output layer by least squares and step the hidden layer only (module docstring); False:
    trainlm's joint step on all weights (identity damping). min_improvement: relative drop of the validation MSE below
    the best so far that resets the patience (smaller gains still keep their weights but do not extend training).
    """

    max_epochs: int = 500
    patience: int = 12
    mu: float = 1e-3
    mu_decrease: float = 0.1
    mu_increase: float = 10.0
    mu_max: float = 1e10
    min_gradient: float = 1e-10
    separable: bool = True
    min_improvement: float = 0.0


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
        jacobian = torch.cat([_hidden_jacobian(g, x), h, torch.ones(n, 1, dtype=x.dtype)], dim=1)
    return y, jacobian


def _hidden_jacobian(g: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
    """d output / d (hidden.weight row-major, hidden.bias) from g = d output / d pre-activation (n, H)."""
    return torch.cat([(g[:, :, None] * x[:, None, :]).reshape(len(x), -1), g], dim=1)


def _mse(network: MLP, x: torch.Tensor, y: torch.Tensor) -> float:
    with torch.no_grad():
        return float(torch.mean((network(x)[:, 0] - y) ** 2))


def _cholesky(matrix: torch.Tensor) -> torch.Tensor | None:
    """Lower Cholesky factor of a symmetric matrix, None where it is not numerically positive definite."""
    factor, info = torch.linalg.cholesky_ex(matrix)
    return factor if int(info) == 0 and bool(torch.isfinite(factor).all()) else None


@dataclass
class _OutputFit:
    """The hidden layer's outputs with a ones column (basis, n x (H+1)), the least-squares output weights on it
    (last: the bias), the Cholesky factor of the basis's Gram matrix, the residuals and their mean square."""

    basis: torch.Tensor
    weights: torch.Tensor
    gram_factor: torch.Tensor
    residual: torch.Tensor
    loss: float


def _fit_output(x: torch.Tensor, y: torch.Tensor, w1: torch.Tensor, b1: torch.Tensor) -> _OutputFit | None:
    """The output layer that fits y best for hidden weights (w1, b1), by least squares (a ridge of 1e-12 of the
    Gram matrix's mean diagonal, raised until it factorises, keeps duplicate or saturated units solvable); None
    where the hidden layer's outputs are not finite."""
    basis = torch.cat([torch.tanh(torch.addmm(b1, x, w1.T)), torch.ones(len(x), 1, dtype=x.dtype)], dim=1)
    if not bool(torch.isfinite(basis).all()):
        return None
    gram = basis.T @ basis
    eye = torch.eye(len(gram), dtype=gram.dtype)
    ridge = 1e-12 * float(torch.diagonal(gram).mean())
    factor = _cholesky(gram + ridge * eye)
    while factor is None and ridge < float(torch.diagonal(gram).mean()):
        ridge *= 100.0
        factor = _cholesky(gram + ridge * eye)
    if factor is None:
        return None
    weights = torch.cholesky_solve((basis.T @ y)[:, None], factor)[:, 0]
    residual = basis @ weights - y
    return _OutputFit(basis, weights, factor, residual, float(residual @ residual) / len(y))


def _set_weights(network: MLP, w1: torch.Tensor, b1: torch.Tensor, output: torch.Tensor) -> None:
    with torch.no_grad():
        network.hidden.weight.copy_(w1)
        network.hidden.bias.copy_(b1)
        network.out.weight.copy_(output[None, :-1])
        network.out.bias.copy_(output[-1:])


def _fit_separable(
    network: MLP,
    train: tuple[torch.Tensor, torch.Tensor],
    validation: tuple[torch.Tensor, torch.Tensor],
    settings: LMSettings,
    on_epoch: EpochReport | None,
) -> FitHistory:
    """Variable-projection LM (module docstring): the network holds every epoch's hidden weights with their
    least-squares output layer."""
    x, y = train
    x_val, y_val = validation
    n_hidden, n_in = network.hidden.weight.shape
    with torch.no_grad():
        w1, b1 = network.hidden.weight.detach().clone(), network.hidden.bias.detach().clone()
    fit = _fit_output(x, y, w1, b1)
    if fit is None:
        raise ValueError("the initial hidden layer gives non-finite outputs")
    _set_weights(network, w1, b1, fit.weights)
    log = TrainingLog(network, settings.patience, fit.loss, _mse(network, x_val, y_val), settings.min_improvement)
    mu = settings.mu
    reason = "max_epochs"
    for epoch in range(1, settings.max_epochs + 1):
        check_stop()
        h = fit.basis[:, :-1]
        jacobian = _hidden_jacobian(fit.weights[:-1] * (1.0 - h * h), x)
        gradient = jacobian.T @ fit.residual
        if float(gradient.abs().max()) < settings.min_gradient * len(y):
            reason = "min_gradient"
            break
        # Kaufman's Jacobian P⊥J (P⊥ projects off the basis): (P⊥J)ᵀ(P⊥J) = JᵀJ - Bᵀ G⁻¹ B with B = basisᵀJ, G = Gram.
        cross = fit.basis.T @ jacobian
        hessian = jacobian.T @ jacobian - cross.T @ torch.cholesky_solve(cross, fit.gram_factor)
        eye = torch.eye(len(hessian), dtype=hessian.dtype)
        trial = None
        while mu <= settings.mu_max:
            factor = _cholesky(hessian + mu * eye)
            if factor is not None:
                step = torch.cholesky_solve(gradient[:, None], factor)[:, 0]
                w1_new = w1 - step[: n_hidden * n_in].reshape(n_hidden, n_in)
                b1_new = b1 - step[n_hidden * n_in :]
                trial = _fit_output(x, y, w1_new, b1_new)
                if trial is not None and math.isfinite(trial.loss) and trial.loss < fit.loss:
                    mu = max(mu * settings.mu_decrease, 1e-20)
                    break
                trial = None
            mu *= settings.mu_increase
        if trial is None:
            reason = "mu_max"
            break
        w1, b1, fit = w1_new, b1_new, trial
        _set_weights(network, w1, b1, fit.weights)
        validation_loss = _mse(network, x_val, y_val)
        stop = log.record(epoch, fit.loss, validation_loss)
        if on_epoch is not None:
            on_epoch(epoch, settings.max_epochs, fit.loss, validation_loss)
        if stop:
            reason = "validation"
            break
    return log.finish(reason)


def _fit_joint(
    network: MLP,
    train: tuple[torch.Tensor, torch.Tensor],
    validation: tuple[torch.Tensor, torch.Tensor],
    settings: LMSettings,
    on_epoch: EpochReport | None,
) -> FitHistory:
    """trainlm's LM: one damped Gauss–Newton step on all weights per epoch, identity damping."""
    x, y = train
    x_val, y_val = validation
    log = TrainingLog(
        network, settings.patience, _mse(network, x, y), _mse(network, x_val, y_val), settings.min_improvement
    )
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
            factor = _cholesky(hessian + mu * eye)
            if factor is not None:
                step = torch.cholesky_solve(gradient[:, None], factor)[:, 0]
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
        validation_loss = _mse(network, x_val, y_val)
        stop = log.record(epoch, loss, validation_loss)
        if on_epoch is not None:
            on_epoch(epoch, settings.max_epochs, loss, validation_loss)
        if stop:
            reason = "validation"
            break
    return log.finish(reason)


def fit_lm(
    network: MLP,
    train: tuple[torch.Tensor, torch.Tensor],
    validation: tuple[torch.Tensor, torch.Tensor],
    settings: LMSettings = LMSettings(),
    on_epoch: EpochReport | None = None,
) -> FitHistory:
    """Train `network` in place on scaled (x (n, n_in), y (n,)) pairs; it ends with the best validation epoch's weights.

    `on_epoch(epoch, max_epochs, training MSE, validation MSE)` is called after every epoch (for progress display).
    """
    if network.out.weight.shape[0] != 1:
        raise ValueError(f"Levenberg–Marquardt here fits one output; the network has {network.out.weight.shape[0]}")
    fit = _fit_separable if settings.separable else _fit_joint
    return fit(network, train, validation, settings, on_epoch)
