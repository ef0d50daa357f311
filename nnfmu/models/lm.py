"""Levenberg–Marquardt training of the one-hidden-layer perceptron, as the thesis (MATLAB's trainlm) did.

Each epoch solves the damped Gauss–Newton system (JᵀJ + mu·I) δ = Jᵀr for all weights at once, with the Jacobian
J of the residuals r written out by hand for tanh-hidden/linear-output nets (exact, and far faster than autograd per
sample). mu shrinks tenfold after a step that lowers the training loss and grows tenfold until one does. The
arithmetic is numpy's float64 on one BLAS thread, JᵀJ as a symmetric rank-k product (half a general product's work),
optionally in float32 (`LMSettings.gram`; the gradient, the solve and the losses that accept or refuse a step stay
float64, so a rounded JᵀJ changes which step is tried but never lets a worse one in); arrays held sample-last
(features x samples) so element-wise work runs along long rows, the Jacobian written into one buffer reused every
epoch, and an accepted trial's hidden activations reused for the next Jacobian.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch
from threadpoolctl import threadpool_limits
from torch.nn.utils import parameters_to_vector, vector_to_parameters

from nnfmu.models.networks import MLP
from nnfmu.models.stopping import FitHistory, TrainingLog
from nnfmu.stopping import check_stop

# The precision of JᵀJ, the epoch's largest product: "float32" forms it from a float32 Jacobian (about 60 % of the
# float64 product's time on the 6-12-1 damper network) and takes the gradient Jᵀr in float64 from the Jacobian's
# structure; the solve and every loss stay float64 either way.
GramPrecision = Literal["float64", "float32"]


@dataclass(frozen=True)
class LMSettings:
    """Levenberg–Marquardt settings; mu values as MATLAB's trainlm, patience counted in epochs, `gram` the precision
    JᵀJ is formed in."""

    max_epochs: int = 500
    patience: int = 12
    mu: float = 1e-3
    mu_decrease: float = 0.1
    mu_increase: float = 10.0
    mu_max: float = 1e10
    min_gradient: float = 1e-10
    gram: GramPrecision = "float64"


class _Perceptron:
    """A one-output tanh perceptron's weights as one vector (torch's parameter order: hidden.weight row-major,
    hidden.bias, out.weight, out.bias) with its forward pass and Jacobian on fixed inputs.

    Arrays are held sample-last (inputs (n_in, n), Jacobian (n_weights, n)): the element-wise work then runs along
    long contiguous rows, several times faster than along rows of a few features.
    """

    def __init__(self, x: np.ndarray, hidden: int, gram: GramPrecision = "float64") -> None:
        self.inputs = np.ascontiguousarray(x.T)
        self.inputs32 = self.inputs.astype(np.float32) if gram == "float32" else self.inputs
        self.m, self.n = self.inputs.shape
        self.hidden = hidden
        self.jacobian = self.new_jacobian(np.float32 if gram == "float32" else np.float64)

    def new_jacobian(self, dtype: type[np.floating]) -> np.ndarray:
        """A Jacobian buffer (n_weights, n) of `dtype`, its output-bias row (all ones) already written."""
        jacobian = np.empty(((self.m + 2) * self.hidden + 1, self.n), dtype=dtype)
        jacobian[-1] = 1.0
        return jacobian

    def split(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Hidden weights (hidden, n_in), hidden biases, output weights and output bias, as views of `weights`."""
        h, m = self.hidden, self.m
        return (
            weights[: h * m].reshape(h, m),
            weights[h * m : h * m + h],
            weights[h * m + h : h * m + 2 * h],
            float(weights[-1]),
        )

    def activations(self, weights: np.ndarray, inputs: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Hidden activations (hidden, n) and output (n,) at `weights` on sample-last `inputs` (default: training)."""
        w1, b1, w2, b2 = self.split(weights)
        pre = w1 @ (self.inputs if inputs is None else inputs)
        pre += b1[:, None]
        hidden = np.tanh(pre, out=pre)
        return hidden, w2 @ hidden + b2

    def slopes(self, weights: np.ndarray, hidden: np.ndarray) -> np.ndarray:
        """d output / d hidden pre-activation (hidden, n) at `weights`, from the hidden activations there."""
        _, _, w2, _ = self.split(weights)
        slope = np.multiply(hidden, hidden)
        np.subtract(1.0, slope, out=slope)
        slope *= w2[:, None]
        return slope

    def gradient(self, slope: np.ndarray, hidden: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """Jᵀr in float64 from the Jacobian's structure (a hidden weight's column is its unit's slope times its
        input), without forming J."""
        weighted = slope * residual
        return np.concatenate(
            ((weighted @ self.inputs.T).ravel(), weighted.sum(axis=1), hidden @ residual, [residual.sum()])
        )

    def fill_jacobian(self, slope: np.ndarray, hidden: np.ndarray, out: np.ndarray) -> np.ndarray:
        """d output / d weights, sample-last (n_weights, n), written into `out` (a `new_jacobian` buffer)."""
        h, m = self.hidden, self.m
        inputs = self.inputs32 if out.dtype == np.float32 else self.inputs
        slope_rows = out[h * m : h * m + h]
        slope_rows[...] = slope
        np.multiply(slope_rows[:, None, :], inputs[None, :, :], out=out[: h * m].reshape(h, m, self.n))
        out[h * m + h : h * m + 2 * h] = hidden
        return out

    def normal_equations(
        self, weights: np.ndarray, hidden: np.ndarray, residual: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Jᵀr and JᵀJ (float64) at `weights`, JᵀJ formed in the precision of the reused Jacobian buffer."""
        slope = self.slopes(weights, hidden)
        jacobian = self.fill_jacobian(slope, hidden, self.jacobian)
        if jacobian.dtype == np.float64:
            return jacobian @ residual, jacobian @ jacobian.T
        return self.gradient(slope, hidden, residual), (jacobian @ jacobian.T).astype(np.float64)


def mlp_jacobian(network: MLP, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Output (n,) and its Jacobian (n, n_weights) w.r.t. `parameters_to_vector(network.parameters())`.

    x: (n, n_in). Parameter order is hidden.weight (row-major), hidden.bias, out.weight, out.bias.
    """
    if network.out.weight.shape[0] != 1:
        raise ValueError(f"Levenberg–Marquardt here fits one output; the network has {network.out.weight.shape[0]}")
    perceptron = _Perceptron(x.detach().numpy(), network.hidden.weight.shape[0])
    weights = parameters_to_vector(network.parameters()).detach().numpy()
    hidden, output = perceptron.activations(weights)
    slope = perceptron.slopes(weights, hidden)
    jacobian = perceptron.fill_jacobian(slope, hidden, perceptron.new_jacobian(np.float64))
    return torch.from_numpy(output), torch.from_numpy(jacobian.T.copy())


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
    if network.out.weight.shape[0] != 1:
        raise ValueError(f"Levenberg–Marquardt here fits one output; the network has {network.out.weight.shape[0]}")
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit(network, train, validation, settings, on_epoch)


def _fit(
    network: MLP,
    train: tuple[torch.Tensor, torch.Tensor],
    validation: tuple[torch.Tensor, torch.Tensor],
    settings: LMSettings,
    on_epoch: Callable[[int, int], None] | None,
) -> FitHistory:
    """`fit_lm`'s loop, on one BLAS thread."""
    params = list(network.parameters())
    perceptron = _Perceptron(train[0].detach().numpy(), network.hidden.weight.shape[0], settings.gram)
    y = train[1].detach().numpy()
    x_val, y_val = np.ascontiguousarray(validation[0].detach().numpy().T), validation[1].detach().numpy()

    def validation_mse(weights: np.ndarray) -> float:
        return float(np.mean((perceptron.activations(weights, x_val)[1] - y_val) ** 2))

    weights = parameters_to_vector(params).detach().numpy().copy()
    hidden, output = perceptron.activations(weights)
    residual = output - y
    log = TrainingLog(network, settings.patience, float(np.mean(residual**2)), validation_mse(weights))
    eye = np.eye(len(weights))
    mu = settings.mu
    reason = "max_epochs"
    for epoch in range(1, settings.max_epochs + 1):
        check_stop()
        gradient, hessian = perceptron.normal_equations(weights, hidden, residual)
        if float(np.abs(gradient).max()) < settings.min_gradient * len(y):
            reason = "min_gradient"
            break
        improved = False
        while mu <= settings.mu_max:
            trial = weights - np.linalg.solve(hessian + mu * eye, gradient)
            trial_hidden, trial_output = perceptron.activations(trial)
            trial_residual = trial_output - y
            loss = float(np.mean(trial_residual**2))
            if math.isfinite(loss) and loss < log.train_loss[-1]:
                mu = max(mu * settings.mu_decrease, 1e-20)
                weights, hidden, residual = trial, trial_hidden, trial_residual
                improved = True
                break
            mu *= settings.mu_increase
        if not improved:
            reason = "mu_max"
            break
        vector_to_parameters(torch.from_numpy(weights.copy()), params)
        stop = log.record(epoch, loss, validation_mse(weights))
        if on_epoch is not None:
            on_epoch(epoch, settings.max_epochs)
        if stop:
            reason = "validation"
            break
    return log.finish(reason)
