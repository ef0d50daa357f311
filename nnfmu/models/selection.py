"""Input selection by sensitivity analysis over the thesis's candidates (displacement, velocity and acceleration at
0, 1 and 2 sample delays, plus the rig's temperature when measured — ORIGIN.md's "ten").

Method: train one network on all candidates, rank each candidate by how much the validation error grows when that
column alone is shuffled (permutation importance, seeded), then add candidates in ranking order and keep the
smallest set whose validation error is within a tolerance of the best set's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from nnfmu.data.denoise import lowpass_channels
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.errors import SettingsError
from nnfmu.models.features import FeatureSpec, Tap
from nnfmu.models.train import Architecture, PreparedData, Progress, TrainSettings, fit_best, prepare_data

CANDIDATE_DELAYS = (0, 1, 2)
# Kinematic candidates per output quantity; the output's direction prefix (e.g. "axial_") is put in front.
KINEMATICS = {
    "force": ("displacement", "velocity", "acceleration"),
    "torque": ("rotation", "angular_velocity", "angular_acceleration"),
}
EXTRA_CANDIDATES = ("temperature",)


@dataclass(frozen=True)
class SelectionSettings:
    """hidden: size of the networks used for ranking and for the forward pass; max_inputs: largest set tried;
    tolerance: relative validation-MSE margin within which the smaller set wins; floor: scaled validation MSE below
    which a set counts as exact (1e-5 = RMS error 0.3 % of the half range; smaller gains are immaterial and come
    from optimiser luck); training: optimiser settings."""

    hidden: int = 5
    max_inputs: int = 4
    tolerance: float = 0.10
    floor: float = 1e-5
    training: TrainSettings = field(default_factory=lambda: TrainSettings(restarts=2))


@dataclass
class SelectionResult:
    """ranking: (feature name, validation-MSE increase when shuffled), most important first; chosen: the selected
    feature names; spec: the feature spec of the chosen set; validation_mse: best validation MSE with the top 1, 2, ...
    features of the ranking."""

    ranking: list[tuple[str, float]]
    chosen: list[str]
    spec: FeatureSpec
    validation_mse: list[float]


def candidate_taps(measurement: Measurement, output: str, delays: tuple[int, ...] = CANDIDATE_DELAYS) -> list[Tap]:
    """Candidate input taps for `output` that the measurement has: its direction's kinematics at `delays`, and the
    extra channels (temperature) undelayed."""
    for quantity, kinematics in KINEMATICS.items():
        if output.endswith(quantity):
            prefix = output[: -len(quantity)]
            break
    else:
        raise SettingsError(f"input selection knows force and torque outputs; {output!r} is neither")
    taps = [Tap(prefix + k, delays) for k in kinematics if prefix + k in measurement]
    taps += [Tap(c) for c in EXTRA_CANDIDATES if c in measurement and c != output]
    if not taps:
        raise DataError(
            f"{measurement.source}: none of the candidate inputs {[prefix + k for k in kinematics]}"
            " is in the measurement"
        )
    return taps


def _validation_mse(network: torch.nn.Module, x: torch.Tensor, y: torch.Tensor) -> float:
    with torch.no_grad():
        return float(torch.mean((network(x)[:, 0] - y) ** 2))


def permutation_ranking(
    network: torch.nn.Module, data: PreparedData, names: list[str], seed: int
) -> list[tuple[str, float]]:
    """Each feature's validation-MSE increase when its column alone is shuffled, largest first."""
    x, y = data.rows("validation")
    base = _validation_mse(network, x, y)
    generator = torch.Generator().manual_seed(seed)
    scores = []
    for j, name in enumerate(names):
        shuffled = x.clone()
        shuffled[:, j] = x[torch.randperm(len(x), generator=generator), j]
        scores.append((name, _validation_mse(network, shuffled, y) - base))
    return sorted(scores, key=lambda item: -item[1])


def spec_of(taps: list[Tap], chosen: list[str], output: str) -> FeatureSpec:
    """Feature spec holding exactly the `chosen` feature names of the candidate taps (in candidate order)."""
    kept = []
    for tap in taps:
        delays = tuple(d for d in tap.delays if tap.feature_name(d) in chosen)
        if delays:
            kept.append(Tap(tap.channel, delays))
    return FeatureSpec(taps=tuple(kept), output=output)


def select_inputs(
    measurement: Measurement,
    output: str,
    settings: SelectionSettings = SelectionSettings(),
    progress: Progress | None = None,
) -> SelectionResult:
    """Rank the candidate inputs of `output` and choose the smallest set that predicts it about as well as any."""
    taps = candidate_taps(measurement, output)
    full = FeatureSpec(taps=tuple(taps), output=output)
    architecture = Architecture("mlp", (settings.hidden,))
    steps = 1 + min(settings.max_inputs, full.n_features)

    def stage(index: int) -> Progress | None:
        if progress is None:
            return None
        return lambda label, done: progress(f"input selection: {label}", (index + done) / steps)

    measurement = lowpass_channels(measurement, full.channels, settings.training.input_cutoff)
    data = prepare_data(measurement, full, settings.training.splits)
    network, _, _, _ = fit_best(data, architecture, settings.training, stage(0))
    ranking = permutation_ranking(network, data, full.feature_names, settings.training.seed)
    errors: list[float] = []
    for count in range(1, steps):
        spec = spec_of(taps, [name for name, _ in ranking[:count]], output)
        subset = prepare_data(measurement, spec, settings.training.splits)
        _, _, trials, _ = fit_best(subset, architecture, settings.training, stage(count))
        errors.append(trials[0].validation_mse)
    best = min(errors)
    good_enough = max(best * (1.0 + settings.tolerance), settings.floor)
    count = next(i + 1 for i, e in enumerate(errors) if e <= good_enough)
    chosen = [name for name, _ in ranking[:count]]
    return SelectionResult(ranking=ranking, chosen=chosen, spec=spec_of(taps, chosen, output), validation_mse=errors)
