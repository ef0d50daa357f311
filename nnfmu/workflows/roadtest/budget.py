"""The road test's error budget: how much of a channel's error against the monolithic reference the networks cause and
how much the coupling causes.

Per system, channel and damper model, against the monolithic reference (truth physics, no coupling):
- `nrmse_total`: the co-simulation with the network FMUs;
- `nrmse_coupling`: the same co-simulation with FMUs that run the truth laws in the networks' place
  (`truth_graphs`): what coupling and sampling alone cost;
- `nrmse_network`: for a channel a network computes (a damper force, a bushing force or torque), that network's FMU
  replayed open loop on the reference's own motion of its element; for a vehicle channel, the co-simulation with
  the networks against the one with the truth FMUs (same coupling, so the difference is the networks');
- `damage_ratio`: rainflow pseudo-damage of the network co-simulation over the reference's.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

from nnfmu.validate import ChannelComparison
from nnfmu.validate.summary import json_float


@dataclass(frozen=True)
class BudgetRow:
    """One channel of one system and damper model; NRMSE [1] against the reference, damage ratio [1] (NaN, null in
    JSON, when the record is too short for it: `not_meaningful` says why)."""

    system: str
    channel: str
    unit: str
    model: str
    nrmse_total: float
    nrmse_network: float
    nrmse_coupling: float
    damage_ratio: float
    not_meaningful: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, object]:
        return {k: (json_float(v) if isinstance(v, float) else v) for k, v in asdict(self).items()}


def budget_rows(
    system: str,
    model: str,
    total: list[ChannelComparison],
    coupling: list[ChannelComparison],
    network: dict[str, ChannelComparison],
) -> list[BudgetRow]:
    """Rows of `model` in `system` from the network co-simulation's comparisons with the reference (`total`), the
    truth co-simulation's (`coupling`, same channels) and the network's own error per channel (`network`)."""
    by_name = {c.name: c for c in coupling}
    return [
        BudgetRow(
            system=system,
            channel=c.name,
            unit=c.unit,
            model=model,
            nrmse_total=c.metrics.nrmse,
            nrmse_network=network[c.name].metrics.nrmse,
            nrmse_coupling=by_name[c.name].metrics.nrmse,
            damage_ratio=c.metrics.pseudo_damage_ratio,
            not_meaningful={"damage_ratio": c.metrics.not_meaningful["pseudo_damage_ratio"]}
            if "pseudo_damage_ratio" in c.metrics.not_meaningful
            else {},
        )
        for c in total
    ]
