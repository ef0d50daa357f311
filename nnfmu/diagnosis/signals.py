"""The signals the effect library computes regressors from: the measured channels of one direction, the rates the
rig did not measure (derived), the measured output and the model's prediction of it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnfmu.data import DataError, Measurement, derive_rates
from nnfmu.data.units import base_name
from nnfmu.diagnosis.errors import DiagnosisError


@dataclass(frozen=True)
class EffectSignals:
    """Everything an effect family may use, by base name (`velocity`, not `axial_velocity`).

    `channels`: the measured and derived channels of the output's direction, shape (n,) each, SI units;
    `derived`: which of them were derived (and how, from `Measurement.notes`); `measured`: the output channel;
    `predicted`: the model's output; `time` [s]; `unknown_to_model`: base names present but not model inputs;
    `raw`: every measured channel by its full name (what an `input:<channel>` candidate reads); `sample_period` [s]:
    the measurement's.
    """

    time: np.ndarray
    channels: dict[str, np.ndarray]
    derived: dict[str, str]
    measured: np.ndarray
    predicted: np.ndarray
    output: str
    unknown_to_model: tuple[str, ...]
    raw: dict[str, np.ndarray]
    sample_period: float

    def has(self, base: str) -> bool:
        return base in self.channels

    def __getitem__(self, base: str) -> np.ndarray:
        return self.channels[base]


def direction_prefix(output: str) -> str:
    """The direction prefix of the output channel: `axial_force` -> `axial_`, `force` -> ``."""
    base = base_name(output)
    return output[: len(output) - len(base)] if base else ""


def build_signals(m: Measurement, predicted: np.ndarray, output: str, model_inputs: tuple[str, ...]) -> EffectSignals:
    """Collect the channels sharing the output's direction prefix, deriving missing rates (Savitzky-Golay)."""
    try:
        full = derive_rates(m)
    except DataError as err:
        raise DiagnosisError(f"{m.source}: cannot derive the rates the effect library needs: {err}") from None
    prefix = direction_prefix(output)
    channels: dict[str, np.ndarray] = {}
    derived: dict[str, str] = {}
    for name, values in full.channels.items():
        base = base_name(name)
        if name == output or base is None or name != prefix + base:
            continue
        channels[base] = np.asarray(values, dtype=float)
        if name not in m.channels:
            derived[base] = full.notes.get(f"derived:{name}", "derived")
    inputs = {base_name(name) for name in model_inputs}
    unknown = tuple(sorted(base for base in channels if base not in inputs and base not in derived))
    return EffectSignals(
        time=np.asarray(m.time, dtype=float),
        channels=channels,
        derived=derived,
        measured=np.asarray(m.channels[output], dtype=float),
        predicted=np.asarray(predicted, dtype=float),
        output=output,
        unknown_to_model=unknown,
        raw={name: np.asarray(values, dtype=float) for name, values in m.channels.items()},
        sample_period=m.sample_period,
    )
