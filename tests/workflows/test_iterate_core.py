"""The iteration loop on numpy plants (fast): a linear SISO plant, a MIMO plant with two actuators and three
responses, a stiffening nonlinear plant, actuator limits, and refused settings."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.workflows.iterate import ActuatorLimits, IterateError, IterateSettings, iterate, parse_band, parse_tolerance
from nnfmu.workflows.iterate.signals import band_filter, fade_weights

DT = 1e-3
DURATION = 12.0
SETTINGS = IterateSettings(noise_duration=40.0, resolution=0.1, band=(0.2, 100.0), tolerance=0.02)


def _resonance(hz: float, damping: float) -> tuple[np.ndarray, np.ndarray]:
    w = 2 * np.pi * hz
    b, a, _ = signal.cont2discrete(([w * w], [1.0, 2 * damping * w, w * w]), DT, method="bilinear")
    return np.ravel(b), np.asarray(a)


BODY, WHEEL = _resonance(1.2, 0.3), _resonance(11.0, 0.2)
REFERENCE_LEVEL = 0.04  # [m] relative body motion at which the nonlinear plant's cubic term is half its linear one


def _filter(coefficients: tuple[np.ndarray, np.ndarray], x: np.ndarray) -> np.ndarray:
    """A mass's motion relative to the post that moves it by `x` (a base-excited resonance minus its base motion,
    like a suspension's stroke: nothing at 0 Hz)."""
    return signal.lfilter(coefficients[0], coefficients[1], x) - x


def _roads(count: int) -> np.ndarray:
    """Known drives (n, count) [m]: class C road tracks at 20 m/s, faded from and back to rest."""
    road = generate_drive(DriveSettings(duration=DURATION - DT, seed=11))
    names = ["actuator_fl_displacement", "actuator_fr_displacement"][:count]
    x = np.column_stack([road[name] for name in names])
    return x * fade_weights(len(x), DT, 0.5)[:, None]


def _siso(x: np.ndarray) -> np.ndarray:
    return np.column_stack([_filter(BODY, x[:, 0]), 30.0 * _filter(WHEEL, x[:, 0])])


def _mimo(x: np.ndarray) -> np.ndarray:
    a, b = x[:, 0], x[:, 1]
    return np.column_stack(
        [_filter(BODY, a) + 0.5 * _filter(BODY, b), _filter(BODY, b) + 0.3 * _filter(WHEEL, a), _filter(WHEEL, a - b)]
    )


def _stiffening(x: np.ndarray) -> np.ndarray:
    """The SISO plant whose slow response stiffens with level (a cubic term on the body channel, scaled on a fixed
    reference level): the noise run's FRF is off at the road's level, so the loop must correct for it."""
    y = _siso(x)
    y[:, 0] += 0.5 * REFERENCE_LEVEL * (y[:, 0] / REFERENCE_LEVEL) ** 3
    return y


def _in_band(a: np.ndarray, b: np.ndarray, band: tuple[float, float] = (2.0, 30.0)) -> float:
    fa, fb = band_filter(a, DT, band), band_filter(b, DT, band)
    return float(np.sqrt(np.mean((fa - fb) ** 2)) / np.sqrt(np.mean(fb**2)))


@pytest.mark.parametrize(
    ("plant", "actuators"), [(_siso, 1), (_mimo, 2), (_stiffening, 1)], ids=["siso", "mimo", "nonlinear"]
)
def test_the_loop_recovers_responses_and_the_drive_in_band(plant, actuators: int) -> None:
    known = _roads(actuators)
    target = plant(known)
    names = [f"y{i}" for i in range(target.shape[1])]
    outcome = iterate(plant, target, DT, names, actuators, SETTINGS)
    assert outcome.converged
    best = outcome.iterations[outcome.best]
    assert all(m["nrmse"] <= 0.02 for m in best.metrics.values())
    for j in range(actuators):
        assert _in_band(best.drive[:, j], known[:, j]) < 0.03
    assert np.all(best.drive[0] == 0.0) and np.all(best.drive[-1] == 0.0)


def test_the_first_drive_alone_misses_the_nonlinear_plant() -> None:
    """The first drive alone (the noise run's inverse) leaves the stiffening plant well off: the iterations of the
    test above are what bring it within 2 %."""
    known = _roads(1)
    target = _stiffening(known)
    outcome = iterate(_stiffening, target, DT, ["a", "b"], 1, IterateSettings(**{**vars(SETTINGS), "iterations": 1}))
    assert max(m["nrmse"] for m in outcome.iterations[0].metrics.values()) > 0.05


def test_every_drive_stays_within_tight_actuator_limits() -> None:
    known = _roads(1)
    limits = ActuatorLimits(stroke=0.02, velocity=0.25, acceleration=30.0)
    settings = IterateSettings(**{**vars(SETTINGS), "limits": limits, "iterations": 4})
    outcome = iterate(_siso, _siso(known), DT, ["a", "b"], 1, settings)
    assert any(it.step_taken < 1.0 for it in outcome.iterations)
    for it in outcome.iterations:
        x = it.drive[:, 0]
        v = np.gradient(x, DT)
        assert np.max(np.abs(x)) <= limits.stroke
        assert np.max(np.abs(v)) <= limits.velocity
        assert np.max(np.abs(np.gradient(v, DT))) <= limits.acceleration
        assert max(it.limit_use.values()) <= 1.0


def test_fewer_targets_than_actuators_are_refused() -> None:
    known = _roads(2)
    with pytest.raises(IterateError, match=r"1 target channel\(s\) for 2 actuators"):
        iterate(_mimo, _mimo(known)[:, :1], DT, ["y0"], 2, SETTINGS)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"band": (5.0, 2.0)}, r"band 5:2 Hz: the low edge must lie below the high edge"),
        ({"iterations": 0}, r"iterations = 0 must lie in 1 to 100"),
        ({"gain": -0.5}, r"gain = -0.5 \[1\] must be a positive number"),
        ({"tolerances": {"body_acceleration": 0.0}}, r"tolerance of body_acceleration = 0.0"),
        ({"noise_duration": 2.0}, r"noise duration 2 s holds fewer than 4 segments"),
    ],
)
def test_bad_settings_are_refused_by_name(options: dict, message: str) -> None:
    with pytest.raises(IterateError, match=message):
        IterateSettings(**options)


def test_band_and_tolerance_texts() -> None:
    assert parse_band("0.5:40") == (0.5, 40.0)
    assert parse_tolerance("0.03,damper_displacement=0.08") == (0.03, {"damper_displacement": 0.08})
    with pytest.raises(IterateError, match=r"--band '40': give LO:HI"):
        parse_band("40")
    with pytest.raises(IterateError, match=r"--tolerance item 'a=b'"):
        parse_tolerance("a=b")


def test_the_command_reports_a_bad_option_as_one_error_line(tmp_path) -> None:
    from typer.testing import CliRunner

    from nnfmu.cli import app

    args = ["iterate", str(tmp_path / "road.csv"), "--system", str(tmp_path / "car"), "--out", str(tmp_path / "out")]
    result = CliRunner().invoke(app, [*args, "--band", "0.5-40"])
    assert result.exit_code == 2
    assert result.output.strip() == "error: --band '0.5-40': give LO:HI in Hz, e.g. 0.1:100"
    result = CliRunner().invoke(app, [*args, "--acceleration-limit", "-1"])
    assert result.exit_code == 2
    assert "actuator acceleration limit = -1.0 m/s^2 must be a positive number" in result.output
    assert not (tmp_path / "out").exists()
