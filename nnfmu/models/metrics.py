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
# times its output weight, summed over the units. A steep valve knee on a velocity scaled over +-1.5 m/s needs input
# weights of 10-15 on units whose tanh is flat away from the knee: nnfmu's own damper-hysteresis default (README walk:
# 70 s dyno record, hidden 12) has a largest |weight| of 14 but moves its scaled output by at most 7.6 per scaled unit
# of error in every input. So an MLP is judged by that largest gain over its record (sum_i |dy/dx_i|, the worst case
# over the errors' signs), against the thesis's 10; weights cancelling each other on nearly collinear inputs still
# give a gain of twice their size. A GRU's rows are not independent, so it keeps the weight rule.
GAIN_WARNING = 10.0


@dataclass(frozen=True)
class SplitMetrics:
    """Metrics of output vs target on one split.

    mse_scaled: mean squared error of the [-1, 1]-scaled target (the thesis's "MSE"); nrmse: RMS error / RMS target;
    r2: 1 - SS_res / SS_tot; slope, intercept: least-squares line output = slope * target + intercept (intercept in
    the output's SI unit); peak_error: max |output - target| in SI units; max_abs_weight: the network's largest
    |weight or bias|; samples: number of samples compared.
    """

    mse_scaled: float
    nrmse: float
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


def gain_warning(gain: float) -> str | None:
    """A warning text when an MLP's input-error gain exceeds GAIN_WARNING, else None."""
    if gain > GAIN_WARNING:
        return (
            f"the network amplifies input errors up to {gain:.3g} times (scaled units) > {GAIN_WARNING:g}: its "
            "large weights do not cancel out (try fewer hidden units, more data or a different seed)"
        )
    return None


def network_warning(network: torch.nn.Module, x: torch.Tensor) -> str | None:
    """The warning about a trained network's input-error amplification over its record's scaled features `x`: the gain
    rule for an MLP, the weight rule for others (GAIN_WARNING)."""
    if isinstance(network, MLP):
        return gain_warning(input_error_gain(network, x))
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
        r2=r_squared(output, target),
        slope=slope,
        intercept=intercept,
        peak_error=float(np.max(np.abs(output - target))),
        max_abs_weight=float(largest_weight),
        samples=int(output.size),
    )
