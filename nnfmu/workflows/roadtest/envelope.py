"""Does the vehicle ask a network to extrapolate? Each network input's signal against the training envelope.

The FMU's `extrapolating` flag applies the same rule sample by sample (an input outside [min, max] of its port);
here the whole time history is summarised per port: its range, the envelope, and the share of samples outside; and,
where the network carries the band its training record excited, the share of the signal's power above that band
(the record holds 1 % there): a car can move a part faster than the rig did without leaving its range.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from nnfmu.component import Component, Port
from nnfmu.data import Measurement
from nnfmu.data.band import BAND_POWER_SHARE, power_above
from nnfmu.export.band import carried_band
from nnfmu.validate.summary import json_float

# An input runs above its training band when it holds more than this share of its power above the band's edge (its
# record held 1 - BAND_POWER_SHARE there): `nnfmu cosim` warns, the road test's report marks the row.
BAND_WARN_SHARE = 0.05


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
    band_edge: float | None = None  # [Hz] the band the training record excited; None: the network carries none
    power_above_band: float | None = None  # [1] share of the signal's power above `band_edge`

    @property
    def range_used(self) -> float:
        """Largest |signal| over the envelope's bound on the same side [1]: > 1 means extrapolation."""
        used = [
            self.signal_max / self.envelope_max if self.envelope_max > 0 else np.inf,
            self.signal_min / self.envelope_min if self.envelope_min < 0 else np.inf,
        ]
        return float(max(used))

    @property
    def above_band(self) -> bool:
        """True when the signal holds more than BAND_WARN_SHARE of its power above its training band."""
        return self.power_above_band is not None and self.power_above_band > BAND_WARN_SHARE

    def to_dict(self) -> dict[str, object]:
        d = {k: (json_float(v) if isinstance(v, float) else v) for k, v in asdict(self).items()}
        return d | {"range_used": json_float(self.range_used), "above_band": self.above_band}


def excursion(
    run: str,
    element: str,
    port: Port,
    signal: np.ndarray,
    band_edge: float | None = None,
    sample_period: float | None = None,
) -> Excursion:
    """`signal` (the values the network input `port` of `element` saw, every `sample_period` s) against the port's
    envelope and, when given, the `band_edge` [Hz] of its training record."""
    signal = np.asarray(signal, dtype=float)
    lo = -np.inf if port.min is None else port.min
    hi = np.inf if port.max is None else port.max
    outside = float(np.mean((signal < lo) | (signal > hi)))
    above = None
    if band_edge is not None:
        if sample_period is None:
            raise ValueError(f"{element}.{port.name}: a band edge needs the signal's sample period")
        above = power_above(signal, sample_period, band_edge)
    return Excursion(
        run,
        element,
        port.name,
        port.unit,
        float(signal.min()),
        float(signal.max()),
        float(lo),
        float(hi),
        outside,
        band_edge,
        above,
    )


def excursions(run: str, elements: list[str], component: Component, m: Measurement) -> list[Excursion]:
    """Every input of `component` at each of `elements` along `m` (channels `<element>_<input>`) against its training
    envelope and the band the component carries for it."""
    band = carried_band(component)
    return [
        excursion(run, element, port, m[f"{element}_{port.name}"], band.get(port.name), m.sample_period)
        for element in elements
        for port in component.inputs
    ]


def envelope_warnings(system: str, used: list[Excursion]) -> list[str]:
    """A line per network input a run drove beyond its training envelope or above its training band: where the
    network extrapolates, a cause of the vehicle's error to weigh before the coupling or the step."""
    lines = []
    for e in used:
        where = f"{system}, {e.run}: {e.element}.{e.port}"
        if e.share_outside > 0:
            lines.append(f"{where} {beyond_range_text(e)}: the network extrapolates there")
        if e.above_band:
            lines.append(f"{where} {above_band_text(e)}")
    return lines


def beyond_range_text(e: Excursion) -> str:
    """What a run beyond the training envelope did, for a warning that names the input first."""
    return (
        f"reached {e.signal_min:.4g} to {e.signal_max:.4g} {e.unit}, {e.range_used:.2f}x its training envelope "
        f"[{e.envelope_min:.4g}, {e.envelope_max:.4g}] {e.unit}, on {e.share_outside:.2%} of the run"
    )


def above_band_text(e: Excursion) -> str:
    """What a run above the training band did, for a warning that names the input first."""
    return (
        f"held {e.power_above_band:.1%} of its power above {e.band_edge:.4g} Hz, the band its training record "
        f"excited (which held {1 - BAND_POWER_SHARE:.0%} there): the network extrapolates in frequency"
    )
