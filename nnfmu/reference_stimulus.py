"""A short input record a step graph carries in its ONNX metadata, from which `nnfmu build` writes reference results.

`nnfmu train` (every `export_onnx`) stores the first samples of the input data the export was verified on, so a
built FMU can carry stimuli and expected outputs (FMI-LS-REF) computed from the graph itself. Stored as JSON under the
ONNX metadata key `nnfmu.reference_stimulus`: the source in words and one list of values per input port, in SI units.
Needs only onnx (no torch): the FMU factory reads it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import onnx

from nnfmu.component import replace_metadata

METADATA_KEY = "nnfmu.reference_stimulus"
FORMAT_VERSION = 1
REFERENCE_SAMPLES = 500  # 0.5 s at 1 kHz: enough to exercise delays, filters and the recurrent state


@dataclass(frozen=True)
class ReferenceStimulus:
    """Input samples per port name (all the same length, finite) and where they come from."""

    source: str
    inputs: dict[str, tuple[float, ...]]

    def __post_init__(self) -> None:
        lengths = {name: len(values) for name, values in self.inputs.items()}
        if not self.inputs or min(lengths.values()) == 0 or len(set(lengths.values())) > 1:
            raise ValueError(f"reference stimulus needs inputs of one non-zero length, got {lengths}")
        for name, values in self.inputs.items():
            bad = next((i for i, v in enumerate(values) if not math.isfinite(v)), None)
            if bad is not None:
                raise ValueError(f"reference stimulus input {name!r} sample {bad} is {values[bad]!r}")

    @property
    def length(self) -> int:
        return len(next(iter(self.inputs.values())))

    @classmethod
    def take(
        cls, channels: Mapping[str, np.ndarray], names: Sequence[str], source: str, samples: int = REFERENCE_SAMPLES
    ) -> "ReferenceStimulus":
        """The first `samples` samples of the channels `names` (the graph's input ports) of `channels`."""
        return cls(source, {n: tuple(float(v) for v in np.asarray(channels[n], dtype=float)[:samples]) for n in names})

    def to_json(self) -> str:
        return json.dumps(
            {
                "format_version": FORMAT_VERSION,
                "source": self.source,
                "inputs": {k: list(v) for k, v in self.inputs.items()},
            },
            allow_nan=False,
        )

    def attach_to(self, model: onnx.ModelProto) -> None:
        """Store this stimulus in the ONNX model's metadata (replacing an earlier one)."""
        replace_metadata(model, METADATA_KEY, self.to_json())

    @classmethod
    def from_onnx(cls, model: onnx.ModelProto) -> "ReferenceStimulus | None":
        """The stimulus stored in `model`, or None; ValueError (naming the key) for a malformed or newer one."""
        for prop in model.metadata_props:
            if prop.key == METADATA_KEY:
                try:
                    data = json.loads(prop.value)
                    if data.get("format_version", FORMAT_VERSION) > FORMAT_VERSION:
                        raise ValueError(f"format {data['format_version']} is newer than this nnfmu's")
                    return cls(
                        str(data["source"]), {str(k): tuple(float(x) for x in v) for k, v in data["inputs"].items()}
                    )
                except (ValueError, KeyError, TypeError, AttributeError) as err:
                    raise ValueError(f"ONNX metadata {METADATA_KEY!r} is malformed: {err}") from err
        return None


def merge_stimuli(stimuli: Sequence[ReferenceStimulus | None]) -> ReferenceStimulus | None:
    """One stimulus for a merged graph: every part's inputs (a port two parts share takes the first part's values),
    cut to the shortest part; None when a part has none."""
    if not stimuli or any(s is None for s in stimuli):
        return None
    n = min(s.length for s in stimuli)
    inputs: dict[str, tuple[float, ...]] = {}
    for stimulus in stimuli:
        for name, values in stimulus.inputs.items():
            inputs.setdefault(name, values[:n])
    sources = "; ".join(dict.fromkeys(s.source for s in stimuli))
    return ReferenceStimulus(f"merged parts' stimuli ({sources})", inputs)
