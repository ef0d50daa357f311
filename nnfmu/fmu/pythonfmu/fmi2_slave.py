"""nnfmu's one generic FMI 2.0 slave (pythonfmu): translates FMI 2 calls to the shared `SampledComponent`.

This file is shipped unchanged in every FMI 2 pythonfmu FMU, copied under a module name unique to that FMU, with
`sampled_component.py` beside it as `<module>_core.py` (builder.py): Python caches modules by name, so two FMUs in
one process never share either. It runs in the importing tool's Python (numpy, onnxruntime) and must not import
nnfmu. pythonfmu 0.7.0 turns any Python exception into fmi2Fatal, so refused calls are logged with status error and
`do_step` returns False (fmi2Discard) while an input holds a refused value.
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path
from typing import Any

from pythonfmu import Boolean, Fmi2Slave, Real
from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Status, Fmi2Variability

# the package's module when imported from nnfmu (the builder), the FMU's `<module>_core.py` inside an FMU
_core = import_module(f"{__package__}.sampled_component" if __package__ else f"{__name__}_core")

_STATUS = {"warning": Fmi2Status.warning, "error": Fmi2Status.error}


class NnfmuSlave(Fmi2Slave):
    """Co-simulation slave of one nnfmu step graph: zero-order-hold outputs, output low-pass, envelope flag."""

    log_categories = _core.LOG_CATEGORIES

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._core = _core.SampledComponent(Path(self.resources), self._report)
        self.description = self._core.description
        for var in self._core.variables:
            self._register(var)

    def _register(self, var: dict[str, Any]) -> None:
        """Register one table entry (in value-reference order, so pythonfmu assigns the same reference)."""
        description = var["description"] or None
        if var["causality"] == "input":
            scalar = Real(var["name"], causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                          description=description)
        elif var["causality"] == "parameter":
            scalar = Real(var["name"], causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                          description=description)
        else:
            kind = Real if var["type"] == "Real" else Boolean
            scalar = kind(var["name"], causality=Fmi2Causality.output, variability=Fmi2Variability.discrete,
                          initial=Fmi2Initial.calculated, description=description)
        self.register_variable(scalar, nested=False)
        if scalar.value_reference != var["value_reference"]:
            raise ValueError(f"{var['name']!r}: pythonfmu gave value reference {scalar.value_reference}, "
                             f"the variable table says {var['value_reference']}")

    def _report(self, message: str, severity: str) -> None:
        self.log(message, _STATUS[severity])

    def setup_experiment(self, start_time: float = 0.0, stop_time: float | None = None,
                         tolerance: float | None = None) -> None:
        self._core.start(start_time)

    def exit_initialization_mode(self) -> None:
        self._core.initialise()

    def do_step(self, current_time: float, step_size: float) -> bool:
        return self._core.step(current_time, step_size)

    def get_real(self, vrs: list[int]) -> list[float]:
        return [self._core.read(vr, "Real", "getReal") for vr in vrs]

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        for vr, value in zip(vrs, values):
            self._core.write(vr, value, "Real", "setReal")

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
