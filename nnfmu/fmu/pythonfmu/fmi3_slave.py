"""nnfmu's one generic FMI 3.0 slave (pythonfmu3): translates FMI 3 calls to the shared `SampledComponent`.

Shipped like the FMI 2 slave (builder.py): unchanged, under a module name unique to its FMU, with
`sampled_component.py` beside it as `<module>_core.py`. pythonfmu3 0.3.4 turns any Python exception into fmi3Fatal,
ignores what a setter returns and does not pass the start time of fmi3EnterInitializationMode to the slave, so
samples count from the first doStep's communication point (which FMI 3 requires to be the start time). Refused calls
are logged with status error and `do_step` returns fmi3Discard while an input holds a refused value.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from pythonfmu3 import (
    Boolean,
    Float64,
    Fmi3Causality,
    Fmi3Initial,
    Fmi3Slave,
    Fmi3Status,
    Fmi3StepResult,
    Fmi3Variability,
)

# the package's module when imported from nnfmu (the builder), the FMU's `<module>_core.py` inside an FMU
_core = import_module(f"{__package__}.sampled_component" if __package__ else f"{__name__}_core")

_STATUS = {"warning": Fmi3Status.warning, "error": Fmi3Status.error}


class NnfmuSlave3(_core.SlaveBridge, Fmi3Slave):
    """Co-simulation slave of one nnfmu step graph: zero-order-hold outputs, output low-pass, envelope flag."""

    runtime_name = "pythonfmu3"

    def _scalar(self, var: dict[str, Any], description: str | None) -> Any:
        """The pythonfmu3 variable of one table entry."""
        if var["causality"] == "input":
            return Float64(
                var["name"],
                causality=Fmi3Causality.input,
                variability=Fmi3Variability.continuous,
                description=description,
            )
        if var["causality"] == "parameter":
            return Float64(
                var["name"],
                causality=Fmi3Causality.parameter,
                variability=Fmi3Variability.fixed,
                initial=Fmi3Initial.exact,
                description=description,
            )
        if var["causality"] == "independent":
            return Float64(
                var["name"],
                causality=Fmi3Causality.independent,
                variability=Fmi3Variability.continuous,
                description=description,
            )
        kind = Float64 if var["type"] == "Real" else Boolean
        return kind(
            var["name"],
            causality=Fmi3Causality.output,
            variability=Fmi3Variability.discrete,
            initial=Fmi3Initial.calculated,
            description=description,
        )

    def _report(self, message: str, severity: str) -> None:
        """Errors always reach the master's logger; warnings only while logging is on (as in the native FMUs)."""
        self.log(message, _STATUS[severity], debug=severity == "warning")

    def do_step(self, current_time: float, step_size: float) -> Fmi3StepResult:
        accepted = self._core.step(current_time, step_size)
        return Fmi3StepResult(status=Fmi3Status.ok if accepted else Fmi3Status.discard)

    def get_float64(self, vrs: list[int]) -> list[float]:
        return self._read_reals(vrs, "getFloat64")

    def set_float64(self, vrs: list[int], values: list[float]) -> None:
        self._write_reals(vrs, values, "setFloat64")
