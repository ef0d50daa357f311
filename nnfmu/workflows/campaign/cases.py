"""A campaign's cases (event x variant), each with the content hash that names its result part.

A case's key is the SHA-256 of everything its rows depend on: the event (name; drive file bytes by hash, or every
generator setting), the variant (name; every element's FMU bytes by hash, connectors, parameter values, wiring), the
coupling settings with their defaults filled in, the engine unless it is the Python master (so parts written before
engines existed stay valid), and the metric settings. Re-running a campaign finds a case's part
by this key, so an unchanged case is skipped and any change to its inputs runs it again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from nnfmu.workflows.campaign.hashing import json_sha256
from nnfmu.workflows.campaign.spec import Campaign, EventSpec, MetricSpec, VariantSpec

PART_FORMAT = 1  # bump when the rows a case writes change meaning, so old parts are not reused


@dataclass(frozen=True)
class Case:
    """One co-simulation of a campaign: what a worker needs to run it and score it (all picklable, no paths)."""

    key: str
    event: EventSpec
    variant: VariantSpec
    coupling: dict[str, Any]
    metrics: MetricSpec
    engine: str = "python"

    @property
    def blob_keys(self) -> tuple[str, ...]:
        """SHA-256 of every file the case needs: the drive file (if any) and each element's FMU."""
        drive = (self.event.drive.sha256,) if self.event.drive else ()
        return drive + tuple(dict.fromkeys(e.fmu.sha256 for e in self.variant.elements))


def case_key(
    event: EventSpec,
    variant: VariantSpec,
    resolved_coupling: dict[str, Any],
    metrics: MetricSpec,
    engine: str = "python",
) -> str:
    return json_sha256(
        {
            "format": PART_FORMAT,
            "event": event.identity(),
            "variant": variant.identity(),
            "coupling": resolved_coupling,
            "metrics": metrics.identity(),
        }
        | ({"engine": engine} if engine != "python" else {})
    )


def expand_cases(campaign: Campaign) -> list[Case]:
    """Every event x variant, events outer: the cases of one event (one drive) are sent close together."""
    resolved = campaign.resolved_coupling()
    return [
        Case(
            case_key(event, variant, resolved, campaign.metrics, campaign.engine),
            event,
            variant,
            dict(campaign.coupling),
            campaign.metrics,
            campaign.engine,
        )
        for event in campaign.events
        for variant in campaign.variants
    ]
