"""Min-max scaling: training extremes map to -1 and 1, and unscale inverts scale exactly."""

import numpy as np

from nnfmu.models.scaling import MinMaxScaler


def test_training_extremes_map_to_minus_one_and_one() -> None:
    x = np.column_stack([np.linspace(-0.05, 0.08, 101), np.linspace(200.0, -3000.0, 101)])
    scaled = MinMaxScaler.fit(x).scale(x)
    np.testing.assert_allclose(scaled.min(axis=0), [-1.0, -1.0], atol=1e-15)
    np.testing.assert_allclose(scaled.max(axis=0), [1.0, 1.0], atol=1e-15)


def test_round_trip_is_exact_to_rounding_inside_and_outside_the_envelope() -> None:
    rng = np.random.default_rng(0)
    train = rng.normal(scale=[0.02, 1.5, 800.0], size=(500, 3))
    scaler = MinMaxScaler.fit(train)
    probe = rng.normal(scale=[0.05, 4.0, 2000.0], size=(200, 3))  # beyond the envelope too
    np.testing.assert_allclose(scaler.unscale(scaler.scale(probe)), probe, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(scaler.scale(scaler.unscale(scaler.scale(probe))), scaler.scale(probe), rtol=1e-13)


def test_constant_column_maps_to_minus_one_without_dividing_by_zero() -> None:
    x = np.column_stack([np.full(10, 3.0), np.arange(10.0)])
    scaler = MinMaxScaler.fit(x)
    scaled = scaler.scale(x)
    assert np.all(scaled[:, 0] == -1.0) and np.all(np.isfinite(scaled))
    np.testing.assert_allclose(scaler.unscale(scaled), x)
