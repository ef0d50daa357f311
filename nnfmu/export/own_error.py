"""The error a network makes on the held-out test split of its own training record, as its description carries it:
read without torch, so a characterisation of an FMU can say which test points it reproduces within that error."""

from __future__ import annotations

import math
from dataclasses import dataclass

from nnfmu.component import Component
from nnfmu.export.errors import ExportError

# The split whose metrics are the network's own error: held out from training and from the choice of network.
OWN_ERROR_SPLIT = "test"


@dataclass(frozen=True)
class OwnError:
    """One output's own error: RMS error in the output's `unit` and NRMSE [1] on the held-out test split (measurement
    noise included, as the record holds it)."""

    output: str
    unit: str
    rms_error: float
    nrmse: float

    def text(self) -> str:
        """`force 3.27 N RMS (NRMSE 0.49 %)`."""
        return f"{self.output} {self.rms_error:.3g} {self.unit} RMS (NRMSE {100 * self.nrmse:.2g} %)"


def _number(component: Component, output: str, key: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value >= 0):
        raise ExportError(
            f"component {component.name!r}: the {OWN_ERROR_SPLIT} split's {key} of output {output!r} is {value!r}; "
            "it must be a finite number >= 0"
        )
    return float(value)


def carried_own_errors(component: Component) -> dict[str, OwnError]:
    """Output name -> its own error, as the component (or each network merged into it) carries it; an output whose
    network carries none (a graph from another tool or an older nnfmu) is left out. ExportError naming the output and
    value when malformed."""
    merged = component.metadata.get("merged_from")
    parts = [p.get("metadata", {}) for p in merged if isinstance(p, dict)] if isinstance(merged, list) else []
    units = {port.name: port.unit for port in component.outputs}
    found: dict[str, OwnError] = {}
    for metadata in parts or [component.metadata]:
        spec = metadata.get("feature_spec") if isinstance(metadata, dict) else None
        metrics = metadata.get("metrics") if isinstance(metadata, dict) else None
        output = spec.get("output") if isinstance(spec, dict) else None
        split = metrics.get(OWN_ERROR_SPLIT) if isinstance(metrics, dict) else None
        if output not in units or not isinstance(split, dict) or "rms_error" not in split:
            continue
        found[output] = OwnError(
            output,
            units[output],
            _number(component, output, "rms_error", split["rms_error"]),
            _number(component, output, "nrmse", split.get("nrmse")),
        )
    return found
