"""nnfmu's one generic FMI 2.0 slave (pythonfmu): translates FMI 2 calls to the shared `SampledComponent`.

This file is shipped unchanged in every FMI 2 pythonfmu FMU, copied under a module name unique to that FMU, with
`sampled_component.py` beside it as `<module>_core.py` (builder.py): Python caches modules by name, so two FMUs in
one process never share either. It runs in the importing tool's Python (numpy, onnxruntime) and must not import
nnfmu. pythonfmu 0.7.0 turns any Python exception into fmi2Fatal and ignores what a setter returns, so refused calls
are logged with status error and `do_step` returns False (fmi2Discard) while an input holds a refused value.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from pythonfmu import Boolean, Fmi2Slave, Real
from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Status, Fmi2Variability

# the package's module when imported from nnfmu (the builder), the FMU's `<module>_core.py` inside an FMU
_core = import_module(f"{__package__}.sampled_component" if __package__ else f"{__name__}_core")

_STATUS = {"warning": Fmi2Status.warning, "error": Fmi2Status.error}


class NnfmuSlave(_core.SlaveBridge, Fmi2Slave):
    """Co-simulation slave of one nnfmu step graph: zero-order-hold outputs, output low-pass, envelope flag."""

    runtime_name = "pythonfmu"

    def _scalar(self, var: dict[str, Any], description: str | None) -> Any:
        """The pythonfmu variable of one table entry."""
        if var["causality"] == "input":
            return Real(
                var["name"],
                causality=Fmi2Causality.input,
                variability=Fmi2Variability.continuous,
                description=description,
            )
        if var["causality"] == "parameter":
            return Real(
                var["name"],
                causality=Fmi2Causality.parameter,
                variability=Fmi2Variability.fixed,
                description=description,
            )
        kind = Real if var["type"] == "Real" else Boolean
        return kind(
            var["name"],
            causality=Fmi2Causality.output,
            variability=Fmi2Variability.discrete,
            initial=Fmi2Initial.calculated,
            description=description,
        )

    def _report(self, message: str, severity: str) -> None:
        self.log(message, _STATUS[severity])

    def setup_experiment(
        self, start_time: float = 0.0, stop_time: float | None = None, tolerance: float | None = None
    ) -> None:
        self._core.start(start_time)

    def do_step(self, current_time: float, step_size: float) -> bool:
        return self._core.step(current_time, step_size)

    def get_real(self, vrs: list[int]) -> list[float]:
        return self._read_reals(vrs, "getReal")

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        self._write_reals(vrs, values, "setReal")
