"""nnfmu's one generic FMI 3.0 slave (pythonfmu3): translates FMI 3 calls to the shared `SampledComponent`.

Shipped like the FMI 2 slave (builder.py): unchanged, under a module name unique to its FMU, with
`sampled_component.py` beside it as `<module>_core.py`. pythonfmu3 0.3.4 turns any Python exception into fmi3Fatal
and does not pass the start time of fmi3EnterInitializationMode to the slave, so samples count from the first
doStep's communication point (which FMI 3 requires to be the start time). Refused calls are logged with status error
and `do_step` returns fmi3Discard while an input holds a refused value.
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path
from typing import Any

from pythonfmu3 import Boolean, Fmi3Causality, Fmi3Initial, Fmi3Slave, Fmi3Status, Fmi3StepResult, Fmi3Variability
from pythonfmu3 import Float64

# the package's module when imported from nnfmu (the builder), the FMU's `<module>_core.py` inside an FMU
_core = import_module(f"{__package__}.sampled_component" if __package__ else f"{__name__}_core")

_STATUS = {"warning": Fmi3Status.warning, "error": Fmi3Status.error}


class NnfmuSlave3(Fmi3Slave):
    """Co-simulation slave of one nnfmu step graph: zero-order-hold outputs, output low-pass, envelope flag."""

    log_categories = _core.LOG_CATEGORIES

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._core = _core.SampledComponent(Path(self.resources), self._report)
        self.description = self._core.description
        for var in self._core.variables:
            self._register(var)

    def _register(self, var: dict[str, Any]) -> None:
        """Register one table entry (in value-reference order, so pythonfmu3 assigns the same reference)."""
        description = var["description"] or None
        if var["causality"] == "input":
            scalar = Float64(var["name"], causality=Fmi3Causality.input, variability=Fmi3Variability.continuous,
                             description=description)
        elif var["causality"] == "parameter":
            scalar = Float64(var["name"], causality=Fmi3Causality.parameter, variability=Fmi3Variability.fixed,
                             initial=Fmi3Initial.exact, description=description)
        elif var["causality"] == "independent":
            scalar = Float64(var["name"], causality=Fmi3Causality.independent,
                             variability=Fmi3Variability.continuous, description=description)
        else:
            kind = Float64 if var["type"] == "Real" else Boolean
            scalar = kind(var["name"], causality=Fmi3Causality.output, variability=Fmi3Variability.discrete,
                          initial=Fmi3Initial.calculated, description=description)
        self.register_variable(scalar, nested=False)
        if scalar.value_reference != var["value_reference"]:
            raise ValueError(f"{var['name']!r}: pythonfmu3 gave value reference {scalar.value_reference}, "
                             f"the variable table says {var['value_reference']}")

    def _report(self, message: str, severity: str) -> None:
        """Errors always reach the master's logger; warnings only while logging is on (as in the native FMUs)."""
        self.log(message, _STATUS[severity], debug=severity == "warning")

    def exit_initialization_mode(self) -> None:
        self._core.initialise()

    def do_step(self, current_time: float, step_size: float) -> Fmi3StepResult:
        accepted = self._core.step(current_time, step_size)
        return Fmi3StepResult(status=Fmi3Status.ok if accepted else Fmi3Status.discard)

    def get_float64(self, vrs: list[int]) -> list[float]:
        return [self._core.read(vr, "Real", "getFloat64") for vr in vrs]

    def set_float64(self, vrs: list[int], values: list[float]) -> None:
        for vr, value in zip(vrs, values):
            self._core.write(vr, value, "Real", "setFloat64")

    def get_boolean(self, vrs: list[int]) -> list[bool]:
        return [bool(self._core.read(vr, "Boolean", "getBoolean")) for vr in vrs]

    def set_boolean(self, vrs: list[int], values: list[bool]) -> None:
        for vr, value in zip(vrs, values):
            self._core.write(vr, value, "Boolean", "setBoolean")

    def _get_fmu_state(self) -> dict[str, Any]:
        return self._core.save()

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        self._core.restore(state)

    _fmu_state_to_bytes = staticmethod(_core.SampledComponent.to_bytes)
    _fmu_state_from_bytes = staticmethod(_core.SampledComponent.from_bytes)
