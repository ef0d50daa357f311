"""The FMU variables of a component and their value references, shared by every backend and FMI version.

Value references are assigned here once, in a fixed order (inputs, outputs, `extrapolating`, parameters, and last
`time`, the independent variable FMI 3 requires), so the model description, the generated C and the Python slave
cannot disagree. Port names are sanitised here too (`nnfmu.fmu.names`), once for every backend.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from nnfmu.component import Component, Port
from nnfmu.fmu.names import unique_names

Causality = Literal["input", "output", "parameter", "independent"]
VarType = Literal["Real", "Boolean"]

DEFAULT_OUTPUT_GAIN = 1.0


@dataclass(frozen=True)
class FmuVariable:
    """One scalar FMU variable."""

    name: str
    value_reference: int
    causality: Causality
    type: VarType
    unit: str
    description: str
    start: float | bool | None
    port_index: int | None = None  # index into component.inputs / component.outputs, for ports


@dataclass(frozen=True)
class FmuVariables:
    """All variables of a component's FMU, grouped by role."""

    inputs: list[FmuVariable]
    outputs: list[FmuVariable]
    extrapolating: FmuVariable
    filter_cutoff: FmuVariable
    output_gain: FmuVariable
    time: FmuVariable

    @property
    def all(self) -> list[FmuVariable]:
        """The variables of an FMI 2.0 FMU (no independent variable), in value-reference order."""
        return [*self.inputs, *self.outputs, self.extrapolating, self.filter_cutoff, self.output_gain]

    def listed(self, fmi_version: int) -> list[FmuVariable]:
        """The variables the model description of `fmi_version` lists: FMI 3 adds `time`."""
        return [self.time, *self.all] if fmi_version == 3 else self.all


BUILT_IN_NAMES = frozenset({"extrapolating", "filter_cutoff", "output_gain", "time"})


def _description(port: Port, name: str) -> str:
    """The port's description, naming the original ONNX name when sanitising changed it."""
    if name == port.name:
        return port.description
    return f"{port.description} (ONNX name {port.name!r})".strip()


def fmu_variables(component: Component) -> FmuVariables:
    """Lay out the FMU variables of `component` with consecutive value references starting at 0."""
    ports = [*component.inputs, *component.outputs]
    names = unique_names([p.name for p in ports], set(BUILT_IN_NAMES))
    vr = 0
    inputs = []
    for i, port in enumerate(component.inputs):
        name = names[vr]
        inputs.append(FmuVariable(name, vr, "input", "Real", port.unit, _description(port, name), 0.0, i))
        vr += 1
    outputs = []
    for i, port in enumerate(component.outputs):
        name = names[vr]
        outputs.append(FmuVariable(name, vr, "output", "Real", port.unit, _description(port, name), None, i))
        vr += 1
    extrapolating = FmuVariable(
        "extrapolating",
        vr,
        "output",
        "Boolean",
        "",
        "true while an input of the latest sample lies outside the training envelope",
        None,
    )
    filter_cutoff = FmuVariable(
        "filter_cutoff",
        vr + 1,
        "parameter",
        "Real",
        "Hz",
        "cut-off frequency of the first-order output low-pass filter (0 turns it off)",
        component.filter_cutoff,
    )
    output_gain = FmuVariable(
        "output_gain",
        vr + 2,
        "parameter",
        "Real",
        "1",
        "gain applied to every output",
        DEFAULT_OUTPUT_GAIN,
    )
    time = FmuVariable("time", vr + 3, "independent", "Real", "s", "simulation time", None)
    return FmuVariables(inputs, outputs, extrapolating, filter_cutoff, output_gain, time)
