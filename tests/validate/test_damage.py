"""Rainflow counting against a hand count, and Basquin pseudo-damage scaling laws."""

import math

import numpy as np
import pytest

from nnfmu.validate.compare import ValidationError, ValidationSettings
from nnfmu.validate.damage import DamageError, pseudo_damage, pseudo_damage_ratio, rainflow_cycles

# ASTM E1049-85 rainflow example (its Fig. 6), counted by hand with the three-point rule:
# half cycles A-B (3), B-C (4), C-D (8), D-G (9), G-H (8), H-I (6) and one full cycle E-F (4).
ASTM_EXAMPLE = np.array([-2.0, 1.0, -3.0, 5.0, -1.0, 3.0, -4.0, 4.0, -2.0])
HAND_COUNT = {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}


def random_load(n: int = 4000, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.convolve(rng.normal(size=n), np.ones(5) / 5, mode="same") * 1e3


def test_rainflow_matches_hand_count():
    ranges, counts = rainflow_cycles(ASTM_EXAMPLE)
    assert dict(zip(ranges.tolist(), counts.tolist())) == HAND_COUNT


def test_rainflow_ignores_points_between_reversals():
    # inserting monotonic intermediate samples (as a denser sampling would) must not change the count
    dense = np.concatenate(
        [np.linspace(a, b, 7)[:-1] for a, b in zip(ASTM_EXAMPLE[:-1], ASTM_EXAMPLE[1:])] + [ASTM_EXAMPLE[-1:]]
    )
    ranges, counts = rainflow_cycles(dense)
    assert dict(zip(ranges.tolist(), counts.tolist())) == pytest.approx(HAND_COUNT)


@pytest.mark.parametrize("slope", [3.0, 5.0, 8.0])
def test_pseudo_damage_of_hand_example(slope):
    expected = sum(n * s**slope for s, n in HAND_COUNT.items())
    assert pseudo_damage(ASTM_EXAMPLE, slope) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("slope", [3.0, 5.0])
def test_scaled_signal_scales_damage_by_factor_to_the_slope(slope):
    load = random_load()
    assert pseudo_damage_ratio(1.1 * load, load, slope) == pytest.approx(1.1**slope, rel=1e-9)


def test_offset_leaves_damage_unchanged():
    load = random_load()
    assert pseudo_damage_ratio(load + 250.0, load, 5.0) == pytest.approx(1.0, rel=1e-9)


def test_no_cycles_gives_nan_ratio_and_zero_damage():
    flat = np.zeros(50)
    assert pseudo_damage(flat, 5.0) == 0.0
    assert np.isnan(pseudo_damage_ratio(random_load(50), flat, 5.0))


def test_non_positive_slope_is_refused():
    with pytest.raises(ValueError, match="slope"):
        pseudo_damage(ASTM_EXAMPLE, 0.0)


@pytest.mark.parametrize("slope", [1e308, 51.0, math.inf, math.nan])
def test_a_slope_past_the_range_is_refused_naming_it(slope):
    """A Basquin slope of 1e308 made every damage inf, which a campaign marked ok."""
    with pytest.raises(DamageError, match=r"Basquin slope = .*\(0, 50\]"):
        pseudo_damage(ASTM_EXAMPLE, slope)
    with pytest.raises(ValidationError, match="Basquin slope"):
        ValidationSettings(slopes={"force": slope})


def test_a_damage_too_large_for_a_float_is_an_error_not_inf():
    """Ranges of 1e7 (a force in N) to the slope 50 overflow: an error naming the slope and the range."""
    with pytest.raises(DamageError, match=r"slope 50.*1e\+07"):
        pseudo_damage(np.array([0.0, 1e7, 0.0, 1e7, 0.0]), 50.0)
    assert math.isfinite(pseudo_damage(np.array([0.0, 1e5, 0.0, 1e5, 0.0]), 50.0))
