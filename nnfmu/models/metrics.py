"""Quality of a trained network on one split, as the thesis judged it (scaled MSE, regression of output on target,
largest weight) plus what a durability engineer reads (NRMSE, peak error)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import torch

from nnfmu.models.networks import MLP
from nnfmu.models.scaling import MinMaxScaler

# The thesis: weights above about 10 amplify input errors; a well-trained net's weights stay within a few units.
WEIGHT_WARNING = 10.0
# What amplifies an input error is the network's gain, not one weight: a unit's input weight times the tanh's slope
# times its output weight, summed over the units. So an MLP is judged by its largest gain over its record (sum_i
# |dy/dx_i|, the worst case over the errors' signs); weights cancelling each other on nearly collinear inputs still
# give a gain of twice their size. A GRU's rows are not independent, so it keeps the weight rule.
# The thesis's 10 is a limit for a component whose output follows its inputs about one to one in scaled units. A
# record can itself be steeper: a damper's bleed slope (8000 N.s/m in rebound) over a velocity scaled on +-3 m/s and
# a force on its 7 kN range rises 6.8 scaled units per scaled unit of velocity near zero, and any network that
# follows the record has that gain there. So the limit is GAIN_EXCESS times the record's own gain (`data_gain`, a
# lower bound) where that is more than GAIN_WARNING. Measured on the default dyno record (`nnfmu rig damper`, then
# `nnfmu train dyno.csv --preset damper-hysteresis`, which picks hidden 12): network gain 11.2, of it 7.8 on the
# velocity where the force's binned slope is 7.5; record gain 4.8 (ratio 2.3). Four leaves room for other seeds and
# sizes; a network whose large weights cancel on collinear inputs exceeds it (tests/models/test_weight_warning.py).
GAIN_WARNING = 10.0
GAIN_EXCESS = 4.0
# The record's own gain: each input's range cut into bins of DATA_GAIN_BIN scaled units, each bin holding at least
# DATA_GAIN_ROWS rows; a difference of neighbouring bins' means within DATA_GAIN_SIGMAS standard errors counts as
# none: four, not two, as the largest of a record's several hundred neighbour pairs is taken (pure noise gave 0.8
# with two, 0 with four).
DATA_GAIN_BIN = 0.01
DATA_GAIN_ROWS = 20
DATA_GAIN_SIGMAS = 4.0


@dataclass(frozen=True)
class SplitMetrics:
    """Metrics of output vs target on one split.

    mse_scaled: mean squared error of the [-1, 1]-scaled target (the thesis's "MSE"); nrmse: RMS error / RMS target;
    rms_error: RMS error in the output's SI unit (the network's own error, which a characterisation judges by);
    r2: 1 - SS_res / SS_tot; slope, intercept: least-squares line output = slope * target + intercept (intercept in
    the output's SI unit); peak_error: max |output - target| in SI units; max_abs_weight: the network's largest
    |weight or bias|; samples: number of samples compared.
    """

    mse_scaled: float
    nrmse: float
    rms_error: float
    r2: float
    slope: float
    intercept: float
    peak_error: float
    max_abs_weight: float
    samples: int

    def as_dict(self) -> dict[str, float]:
        return {k: (int(v) if k == "samples" else float(v)) for k, v in asdict(self).items()}


def nrmse(output: np.ndarray, target: np.ndarray) -> float:
    """RMS of the error over the RMS of the target (inf for an all-zero target with a non-zero error)."""
    error = float(np.sqrt(np.mean((output - target) ** 2)))
    scale = float(np.sqrt(np.mean(target**2)))
    return error / scale if scale > 0 else (0.0 if error == 0 else float("inf"))


def r_squared(output: np.ndarray, target: np.ndarray) -> float:
    """Coefficient of determination of the output as a prediction of the target (1 = perfect).

    A constant target explains nothing: it gets 1 for an exact output and 0 otherwise, so the value stays finite.
    """
    ss_res = float(np.sum((target - output) ** 2))
    ss_tot = float(np.sum((target - np.mean(target)) ** 2))
    if ss_tot == 0:
        return 1.0 if ss_res == 0 else 0.0
    return 1.0 - ss_res / ss_tot


def regression_line(output: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """(slope, intercept) of the least-squares line output = slope * target + intercept.

    A constant target has no slope; it gets (0, mean output) so the metrics stay finite JSON numbers.
    """
    t = target - np.mean(target)
    denominator = float(np.sum(t**2))
    if denominator == 0:
        return 0.0, float(np.mean(output))
    slope = float(np.sum(t * (output - np.mean(output))) / denominator)
    return slope, float(np.mean(output) - slope * np.mean(target))


def max_abs_weight(network: torch.nn.Module) -> float:
    """Largest |weight or bias| of the network."""
    return max(float(p.detach().abs().max()) for p in network.parameters())


def input_error_gain(network: MLP, x: torch.Tensor) -> float:
    """Largest over the rows of `x` (scaled features, (n, inputs)) of sum_i |d output / d x_i| in scaled units: how far
    an error of one scaled unit in every input moves the scaled output at worst."""
    rows = x.detach().clone().requires_grad_(True)
    (gradient,) = torch.autograd.grad(network(rows)[:, 0].sum(), rows)
    return float(gradient.abs().sum(dim=1).max())


def data_gain(x: np.ndarray, y: np.ndarray) -> float:
    """The record's own input-error gain in scaled units: a lower bound on the gain (sum_i |dy/dx_i|) of any smooth
    network that reproduces the record's mean output. Along each input the rows are binned by DATA_GAIN_BIN; between
    neighbouring bins of DATA_GAIN_ROWS rows or more, the mean output's difference over the largest difference of the
    inputs' means (the max-norm, whose dual is the gain's sum) bounds the gain from below. A difference within
    DATA_GAIN_SIGMAS standard errors counts as none, in the output and in every other input, so that noise neither
    raises nor lowers the bound.

    x: (n, inputs) scaled features; y: (n,) scaled output; 0 where no two neighbouring bins qualify."""
    x = np.asarray(x, dtype=np.float64)
    columns = np.column_stack([x, np.asarray(y, dtype=np.float64)])
    best = 0.0
    for i in range(x.shape[1]):
        key = np.floor(x[:, i] / DATA_GAIN_BIN).astype(np.int64)
        bins, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        full = counts >= DATA_GAIN_ROWS
        sums, squares = np.zeros((len(bins), columns.shape[1])), np.zeros((len(bins), columns.shape[1]))
        np.add.at(sums, inverse, columns)
        np.add.at(squares, inverse, columns**2)
        mean = (sums / counts[:, None])[full]
        error2 = (np.maximum(squares / counts[:, None] - (sums / counts[:, None]) ** 2, 0.0) / counts[:, None])[full]
        neighbours = np.flatnonzero(np.diff(bins[full]) == 1)
        if neighbours.size == 0:
            continue
        step = np.abs(mean[neighbours + 1] - mean[neighbours])
        step = np.maximum(step - DATA_GAIN_SIGMAS * np.sqrt(error2[neighbours + 1] + error2[neighbours]), 0.0)
        run = np.maximum(np.abs(mean[neighbours + 1, i] - mean[neighbours, i]), step[:, :-1].max(axis=1))
        best = max(best, float(np.max(step[:, -1] / run)))
    return best


def gain_limit(own: float) -> float:
    """The largest gain an MLP may have on a record whose own gain is `own`: GAIN_WARNING, or GAIN_EXCESS times a
    steeper record's own."""
    return max(GAIN_WARNING, GAIN_EXCESS * own)


def gain_warning(gain: float, own: float = 0.0) -> str | None:
    """A warning text when an MLP's input-error gain exceeds `gain_limit` of the record's own gain, else None."""
    if gain > gain_limit(own):
        return (
            f"the network amplifies input errors up to {gain:.3g} times (scaled units), more than "
            f"{GAIN_WARNING:g} and {GAIN_EXCESS:g} times the record's own {own:.2g}: its large weights do not cancel "
            "out (try fewer hidden units, more data or a different seed)"
        )
    return None


def network_warning(network: torch.nn.Module, x: torch.Tensor, y: torch.Tensor) -> str | None:
    """The warning about a trained network's input-error amplification over its record (scaled features `x`, scaled
    output `y`): the gain rule against the record's own gain for an MLP, the weight rule for others."""
    if isinstance(network, MLP):
        return gain_warning(input_error_gain(network, x), data_gain(x.detach().numpy(), y.detach().numpy()))
    return weight_warning(max_abs_weight(network))


def weight_warning(largest: float) -> str | None:
    """A warning text when the largest weight exceeds WEIGHT_WARNING, else None."""
    if largest > WEIGHT_WARNING:
        return (
            f"largest |weight| is {largest:.3g} > {WEIGHT_WARNING:g}: large weights amplify input errors "
            "(try fewer hidden units, more data or a different seed)"
        )
    return None


def split_metrics(
    output: np.ndarray, target: np.ndarray, target_scaler: MinMaxScaler, largest_weight: float
) -> SplitMetrics:
    """Metrics of `output` against `target`, both (n,) in SI units, n >= 1."""
    output = np.asarray(output, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    if output.shape != target.shape or output.ndim != 1 or output.size == 0:
        raise ValueError(f"output {output.shape} and target {target.shape} must be equal, non-empty 1-D arrays")
    scaled_error = target_scaler.scale(output) - target_scaler.scale(target)
    slope, intercept = regression_line(output, target)
    return SplitMetrics(
        mse_scaled=float(np.mean(scaled_error**2)),
        nrmse=nrmse(output, target),
        rms_error=float(np.sqrt(np.mean((output - target) ** 2))),
        r2=r_squared(output, target),
        slope=slope,
        intercept=intercept,
        peak_error=float(np.max(np.abs(output - target))),
        max_abs_weight=float(largest_weight),
        samples=int(output.size),
    )
