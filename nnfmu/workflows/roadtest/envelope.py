"""Does the vehicle ask a network to extrapolate? Each network input's signal against the training envelope.

The FMU's `extrapolating` flag applies the same rule sample by sample (an input outside [min, max] of its port);
here the whole time history is summarised per port: its range, the envelope, and the share of samples outside.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from nnfmu.component import Port
from nnfmu.validate.summary import json_float


@dataclass(frozen=True)
class Excursion:
    """Signal range of one network input in one run against the port's training envelope (port unit)."""

    run: str
    element: str
    port: str
    unit: str
    signal_min: float
    signal_max: float
    envelope_min: float
    envelope_max: float
    share_outside: float

    @property
    def range_used(self) -> float:
        """Largest |signal| over the envelope's bound on the same side [1]: > 1 means extrapolation."""
        used = [
            self.signal_max / self.envelope_max if self.envelope_max > 0 else np.inf,
            self.signal_min / self.envelope_min if self.envelope_min < 0 else np.inf,
        ]
        return float(max(used))

    def to_dict(self) -> dict[str, object]:
        d = {k: (json_float(v) if isinstance(v, float) else v) for k, v in asdict(self).items()}
        return d | {"range_used": json_float(self.range_used)}


def excursion(run: str, element: str, port: Port, signal: np.ndarray) -> Excursion:
    """`signal` (the values the network input `port` of `element` saw) against the port's envelope."""
    signal = np.asarray(signal, dtype=float)
    lo = -np.inf if port.min is None else port.min
    hi = np.inf if port.max is None else port.max
    outside = float(np.mean((signal < lo) | (signal > hi)))
    return Excursion(
        run, element, port.name, port.unit, float(signal.min()), float(signal.max()), float(lo), float(hi), outside
    )
