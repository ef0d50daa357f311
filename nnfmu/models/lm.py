"""Levenberg–Marquardt training of the one-hidden-layer perceptron, as the thesis (MATLAB's trainlm) did.

Each epoch solves the damped Gauss–Newton system (JᵀJ + mu·I) δ = Jᵀr for all weights at once, with the Jacobian
J of the residuals r written out by hand for tanh-hidden/linear-output nets (exact, and far faster than autograd per
sample). mu shrinks tenfold after a step that lowers the training loss and grows tenfold until one does. The
arithmetic is numpy's float64 on one BLAS thread: JᵀJ as a symmetric rank-k product (half a general product's work)
over each half of the samples, the halves summed (at a search's end the second half runs on a core the other runs
left idle), arrays held sample-last (features x samples) so element-wise work runs along long rows, the Jacobian of
each half written into one buffer reused every epoch, and an accepted trial's hidden activations reused for the next
Jacobian.

The steps may be taken in other coordinates of the inputs than the scaled ones the network sees
(`LMSettings.inputs`): mu·I damps every weight alike, so on strongly correlated inputs (a damper's velocity and its
high-passes, up to 0.9994) trainlm's raw coordinates spend many epochs along their small differences. The hidden
layer's weights are carried into those coordinates at the start and back after every epoch, so the network keeps its
form and only the path of the fit changes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import torch
from threadpoolctl import threadpool_limits
from torch.nn.utils import parameters_to_vector, vector_to_parameters

from nnfmu.errors import SettingsError
from nnfmu.models.networks import MLP
from nnfmu.models.stopping import FitHistory, TrainingLog
from nnfmu.stopping import check_stop

# Jacobian entries of a half below which it is computed here rather than on a spare core: handing a task to another
# thread costs tens of microseconds. Per epoch, 100 epochs of one fit on 2 idle cores (29 Nov): 26 000 entries 0.043 ms
# here against 0.057 ms lent, 93 000 0.124 against 0.127 ms, 248 000 0.206 against 0.172 ms, 776 000 (the 6-12-1
# damper network on 16 000 rows) 0.99 against 0.66 ms.
MIN_LENT_JACOBIAN = 200_000
# Coordinates of the inputs LM steps in: the scaled inputs as given (trainlm), each centred and divided by its
# standard deviation over the training rows, or centred and decorrelated to unit covariance.
INPUT_COORDINATES = ("raw", "standardised", "whitened")
# Eigenvalues of the training inputs' covariance below this fraction of the largest are raised to it when whitening
# (a constant or duplicated input is then scaled, not divided by zero).
WHITENING_FLOOR = 1e-12
# Runs a task on a spare core and returns its future, or None when no core is spare (the caller runs it itself).
Lend = Callable[[Callable[[], Any]], "Future[Any] | None"]


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
    inputs: str = "raw"

    def __post_init__(self) -> None:
        check_input_coordinates("inputs", self.inputs)


def check_input_coordinates(name: str, value: str) -> None:
    """SettingsError naming setting `name` and its `value` unless the value is one of INPUT_COORDINATES."""
    if value not in INPUT_COORDINATES:
        raise SettingsError(f"{name} must be one of {', '.join(INPUT_COORDINATES)}, got {value!r}")


@dataclass(frozen=True)
class _InputCoordinates:
    """Affine coordinates z = transform @ (x - mean) of sample-last inputs x, and the hidden weights' image in them."""

    mean: np.ndarray
    transform: np.ndarray
    inverse: np.ndarray

    @classmethod
    def of(cls, kind: str, inputs: np.ndarray) -> _InputCoordinates:
        """`kind`'s coordinates ("standardised" or "whitened") of sample-last training `inputs` (n_in, n)."""
        mean = inputs.mean(axis=1)
        if kind == "standardised":
            scale = inputs.std(axis=1)
            scale[scale == 0] = 1.0
            return cls(mean, np.diag(1 / scale), np.diag(scale))
        values, vectors = np.linalg.eigh(np.atleast_2d(np.cov(inputs)))
        values = np.maximum(values, WHITENING_FLOOR * max(float(values.max()), np.finfo(float).tiny))
        return cls(mean, (vectors / np.sqrt(values)).T, vectors * np.sqrt(values))

    def inputs(self, x: np.ndarray) -> np.ndarray:
        """Sample-last inputs `x` in these coordinates, contiguous."""
        return np.ascontiguousarray(self.transform @ (x - self.mean[:, None]))

    def into_new(self, weights: np.ndarray, hidden: int) -> np.ndarray:
        """Weights of the network on raw inputs as weights of the same function on these coordinates."""
        out, m = weights.copy(), len(self.mean)
        w1 = weights[: hidden * m].reshape(hidden, m)
        out[: hidden * m] = (w1 @ self.inverse).ravel()
        out[hidden * m : hidden * m + hidden] += w1 @ self.mean
        return out

    def into_raw(self, weights: np.ndarray, hidden: int) -> np.ndarray:
        """Weights on these coordinates as weights of the same function on the raw inputs (`into_new` undone)."""
        out, m = weights.copy(), len(self.mean)
        w1 = weights[: hidden * m].reshape(hidden, m) @ self.transform
        out[: hidden * m] = w1.ravel()
        out[hidden * m : hidden * m + hidden] -= w1 @ self.mean
        return out


class _Perceptron:
    """A one-output tanh perceptron's weights as one vector (torch's parameter order: hidden.weight row-major,
    hidden.bias, out.weight, out.bias) with its forward pass and Jacobian on fixed inputs.

    Arrays are held sample-last (inputs (n_in, n), Jacobian (n_weights, n)): the element-wise work then runs along
    long contiguous rows, several times faster than along rows of a few features.
    """

    def __init__(self, x: np.ndarray, hidden: int) -> None:
        self.inputs = np.ascontiguousarray(x.T)
        self.m, self.n = self.inputs.shape
        self.hidden = hidden
        # The samples in two halves, each with its own contiguous Jacobian buffer (reused every epoch)
        self.halves = (slice(0, self.n // 2), slice(self.n // 2, self.n))
        self.jacobians = tuple(np.empty(((self.m + 2) * hidden + 1, part.stop - part.start)) for part in self.halves)
        for jacobian in self.jacobians:
            jacobian[-1] = 1.0

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

    def fill_jacobian(self, weights: np.ndarray, hidden: np.ndarray, half: int) -> np.ndarray:
        """d output / d weights on the samples of half `half`, sample-last (n_weights, samples), from the activations
        at `weights`, in that half's buffer."""
        h, m = self.hidden, self.m
        _, _, w2, _ = self.split(weights)
        columns, jacobian = self.halves[half], self.jacobians[half]
        samples = columns.stop - columns.start
        slope = jacobian[h * m : h * m + h]  # d output / d hidden pre-activation
        np.multiply(hidden[:, columns], hidden[:, columns], out=slope)
        np.subtract(1.0, slope, out=slope)
        slope *= w2[:, None]
        np.multiply(slope[:, None, :], self.inputs[None, :, columns], out=jacobian[: h * m].reshape(h, m, samples))
        jacobian[h * m + h : h * m + 2 * h] = hidden[:, columns]
        return jacobian

    def normal_equations(
        self, weights: np.ndarray, hidden: np.ndarray, residual: np.ndarray, lend: Lend | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """JᵀJ and Jᵀr at `weights`, each the sum of the two halves' products in a fixed order: the second half runs
        on a core `lend` spares when it spares one (a search's last runs), here otherwise, with the same result
        either way."""

        def products(half: int) -> tuple[np.ndarray, np.ndarray]:
            jacobian = self.fill_jacobian(weights, hidden, half)
            return jacobian @ jacobian.T, jacobian @ residual[self.halves[half]]

        lent = None if lend is None or self.jacobians[1].size < MIN_LENT_JACOBIAN else lend(partial(products, 1))
        hessian, gradient = products(0)
        hessian_2, gradient_2 = products(1) if lent is None else lent.result()
        hessian += hessian_2
        gradient += gradient_2
        return hessian, gradient


def mlp_jacobian(network: MLP, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Output (n,) and its Jacobian (n, n_weights) w.r.t. `parameters_to_vector(network.parameters())`.

    x: (n, n_in). Parameter order is hidden.weight (row-major), hidden.bias, out.weight, out.bias.
    """
    if network.out.weight.shape[0] != 1:
        raise ValueError(f"Levenberg–Marquardt here fits one output; the network has {network.out.weight.shape[0]}")
    perceptron = _Perceptron(x.detach().numpy(), network.hidden.weight.shape[0])
    weights = parameters_to_vector(network.parameters()).detach().numpy()
    hidden, output = perceptron.activations(weights)
    jacobian = np.hstack([perceptron.fill_jacobian(weights, hidden, half) for half in (0, 1)])
    return torch.from_numpy(output), torch.from_numpy(jacobian.T.copy())


def fit_lm(
    network: MLP,
    train: tuple[torch.Tensor, torch.Tensor],
    validation: tuple[torch.Tensor, torch.Tensor],
    settings: LMSettings = LMSettings(),
    on_epoch: Callable[[int, int], None] | None = None,
    lend: Lend | None = None,
) -> FitHistory:
    """Train `network` in place on scaled (x (n, n_in), y (n,)) pairs; it ends with the best validation epoch's weights.

    `on_epoch(epoch, max_epochs)` is called after every epoch (for progress display); `lend` gives each epoch's
    second half of JᵀJ to a spare core when there is one (`nnfmu.models.cores.SpareCores.lend`).
    """
    if network.out.weight.shape[0] != 1:
        raise ValueError(f"Levenberg–Marquardt here fits one output; the network has {network.out.weight.shape[0]}")
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit(network, train, validation, settings, on_epoch, lend)


def _fit(
    network: MLP,
    train: tuple[torch.Tensor, torch.Tensor],
    validation: tuple[torch.Tensor, torch.Tensor],
    settings: LMSettings,
    on_epoch: Callable[[int, int], None] | None,
    lend: Lend | None,
) -> FitHistory:
    """`fit_lm`'s loop, on one BLAS thread."""
    params = list(network.parameters())
    hidden_units = network.hidden.weight.shape[0]
    x_train = np.ascontiguousarray(train[0].detach().numpy().T)
    x_val, y_val = np.ascontiguousarray(validation[0].detach().numpy().T), validation[1].detach().numpy()
    coordinates = None if settings.inputs == "raw" else _InputCoordinates.of(settings.inputs, x_train)
    if coordinates is not None:
        x_train, x_val = coordinates.inputs(x_train), coordinates.inputs(x_val)
    perceptron = _Perceptron(x_train.T, hidden_units)
    y = train[1].detach().numpy()

    def validation_mse(weights: np.ndarray) -> float:
        return float(np.mean((perceptron.activations(weights, x_val)[1] - y_val) ** 2))

    weights = parameters_to_vector(params).detach().numpy().copy()
    if coordinates is not None:
        weights = coordinates.into_new(weights, hidden_units)
    hidden, output = perceptron.activations(weights)
    residual = output - y
    log = TrainingLog(network, settings.patience, float(np.mean(residual**2)), validation_mse(weights))
    eye = np.eye(len(weights))
    mu = settings.mu
    reason = "max_epochs"
    for epoch in range(1, settings.max_epochs + 1):
        check_stop()
        hessian, gradient = perceptron.normal_equations(weights, hidden, residual, lend)
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
        raw = weights.copy() if coordinates is None else coordinates.into_raw(weights, hidden_units)
        vector_to_parameters(torch.from_numpy(raw), params)
        stop = log.record(epoch, loss, validation_mse(weights))
        if on_epoch is not None:
            on_epoch(epoch, settings.max_epochs)
        if stop:
            reason = "validation"
            break
    return log.finish(reason)
