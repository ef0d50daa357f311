"""Metrics against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nnfmu.models.metrics import (
    WEIGHT_WARNING,
    max_abs_weight,
    nrmse,
    r_squared,
    regression_line,
    split_metrics,
    weight_warning,
)
from nnfmu.models.networks import MLP
from nnfmu.models.scaling import MinMaxScaler


def test_perfect_fit():
    target = np.array([-2.0, 0.0, 1.0, 5.0])
    m = split_metrics(target.copy(), target, MinMaxScaler.fit(target), largest_weight=3.0)
    assert m.mse_scaled == 0.0 and m.nrmse == 0.0 and m.r2 == 1.0 and m.peak_error == 0.0
    assert m.slope == pytest.approx(1.0) and m.intercept == pytest.approx(0.0, abs=1e-12)
    assert m.max_abs_weight == 3.0 and m.samples == 4


def test_regression_line_of_affine_output():
    target = np.linspace(-1.0, 3.0, 9)
    slope, intercept = regression_line(2.0 * target + 1.0, target)
    assert slope == pytest.approx(2.0) and intercept == pytest.approx(1.0)


def test_hand_computed_values():
    target = np.array([1.0, -1.0, 1.0, -1.0])
    output = np.array([1.5, -1.0, 1.0, -1.0])  # one error of 0.5
    scaler = MinMaxScaler.fit(target)  # gain 1: scaled error = SI error
    m = split_metrics(output, target, scaler, largest_weight=0.0)
    assert m.mse_scaled == pytest.approx(0.25 / 4)
    assert m.nrmse == pytest.approx(np.sqrt(0.25 / 4) / 1.0)
    assert m.rms_error == pytest.approx(np.sqrt(0.25 / 4))  # in the output's unit, whatever the scaler
    assert m.r2 == pytest.approx(1.0 - 0.25 / 4.0)
    assert m.peak_error == pytest.approx(0.5)
    assert nrmse(output, target) == m.nrmse and r_squared(output, target) == m.r2


def test_scaled_mse_uses_the_target_scaler():
    target = np.array([0.0, 10.0])
    output = np.array([1.0, 10.0])
    m = split_metrics(output, target, MinMaxScaler.fit(target), largest_weight=0.0)
    assert m.mse_scaled == pytest.approx((0.2**2) / 2)  # gain 2/10: an error of 1 N is 0.2 scaled
    assert m.rms_error == pytest.approx(np.sqrt(1.0 / 2))  # 1 N of error on one of two samples, in N


def test_constant_target_stays_finite():
    target = np.full(5, 2.0)
    m = split_metrics(target + 1.0, target, MinMaxScaler.fit(np.array([0.0, 4.0])), largest_weight=0.0)
    assert np.isfinite([m.slope, m.intercept, m.r2]).all() and m.r2 == 0.0


def test_largest_weight_and_warning():
    net = MLP(2, 3)
    with torch.no_grad():
        for p in net.parameters():
            p.fill_(0.5)
        net.out.weight[0, 1] = -12.0
    assert max_abs_weight(net) == 12.0
    assert "12" in weight_warning(12.0)
    assert weight_warning(WEIGHT_WARNING) is None


def test_shape_mismatch_is_refused():
    with pytest.raises(ValueError, match="1-D"):
        split_metrics(np.zeros(3), np.zeros(4), MinMaxScaler.fit(np.array([0.0, 1.0])), 0.0)
