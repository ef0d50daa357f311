"""fmpy alone as the master of the FMU contract suite (no nnfmu code runs the FMU): an instance of an FMI 2 or FMI 3
co-simulation FMU with its log captured, set/get by variable name, and whole runs as output rows comparable with
`native_fmu_helpers.Reference.simulate`."""

from __future__ import annotations

import itertools
import shutil
import tempfile
from ctypes import byref, c_void_p
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.fmi3 import FMU3Slave
from fmpy.logging import addLoggerProxy

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3  # fmi2Status and fmi3Status agree on these

# fmpy's FMI 2 logger proxy formats messages but holds one logger per process: every instance registers the same
# callback, and its componentEnvironment (a key) says which instance's list a message goes to.
_SINKS: dict[int, list[tuple[int, str, str]]] = {}
_KEYS = itertools.count(1)


def _route(env, instance_name, status, category, message) -> None:  # noqa: ANN001 (ctypes callback)
    sink = _SINKS.get(env or 0)
    if sink is not None:
        sink.append((status, (category or b"").decode(errors="replace"), (message or b"").decode(errors="replace")))


_LOGGER = fmi2CallbackLoggerTYPE(_route)


class Master:
    """One instance of `fmu` driven by fmpy; `messages` holds what it logged as (status, category, message)."""

    def __init__(self, fmu: Path, name: str = "instance", logging_on: bool = True) -> None:
        self.description = read_model_description(str(fmu))
        self.fmi = 3 if self.description.fmiVersion.startswith("3") else 2
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.inputs = [v.name for v in self.description.modelVariables if v.causality == "input"]
        self.outputs = [
            v.name for v in self.description.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")
        ]
        self.messages: list[tuple[int, str, str]] = []
        self._folder = tempfile.mkdtemp(prefix="contract-", dir=Path(fmu).resolve().parent)
        directory = extract(str(fmu), unzipdir=self._folder)
        kwargs = dict(
            guid=self.description.guid,
            unzipDirectory=directory,
            instanceName=name,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
        )
        self._key = next(_KEYS)
        if self.fmi == 2:
            self.fmu = FMU2Slave(**kwargs)
            _SINKS[self._key] = self.messages
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = _LOGGER
            callbacks.allocateMemory = defaultCallbacks.allocateMemory
            callbacks.freeMemory = defaultCallbacks.freeMemory
            callbacks.componentEnvironment = c_void_p(self._key)
            addLoggerProxy(byref(callbacks))
            self._callbacks = callbacks  # the FMU keeps a pointer to them
            self.fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)
        else:
            self.fmu = FMU3Slave(**kwargs)
            self.fmu.instantiate(loggingOn=logging_on, logMessage=self._log3)
        self._open = True

    def _log3(self, env, status, category, message) -> None:  # noqa: ANN001 (ctypes callback)
        self.messages.append(
            (status, (category or b"").decode(errors="replace"), (message or b"").decode(errors="replace"))
        )

    def vrs(self, names: list[str]) -> list[int]:
        return [self.variables[n].valueReference for n in names]

    def set_real(self, names: list[str], values) -> None:  # noqa: ANN001 (any sequence of numbers)
        setter = self.fmu.setReal if self.fmi == 2 else self.fmu.setFloat64
        setter(self.vrs(names), [float(v) for v in values])

    def get_real(self, names: list[str]) -> np.ndarray:
        getter = self.fmu.getReal if self.fmi == 2 else self.fmu.getFloat64
        return np.array(getter(self.vrs(names)))

    def extrapolating(self) -> bool:
        return bool(self.fmu.getBoolean(self.vrs(["extrapolating"]))[0])

    def outputs_now(self) -> np.ndarray:
        return self.get_real(self.outputs)

    def enter_initialization(self, start: float = 0.0) -> None:
        if self.fmi == 2:
            self.fmu.setupExperiment(startTime=start)
            self.fmu.enterInitializationMode()
        else:
            self.fmu.enterInitializationMode(startTime=start)

    def initialize(self, inputs, start: float = 0.0, parameters: dict[str, float] | None = None) -> None:  # noqa: ANN001
        self.enter_initialization(start)
        if parameters:
            self.set_real(list(parameters), list(parameters.values()))
        self.set_real(self.inputs, inputs)
        self.fmu.exitInitializationMode()

    def do_step(self, t: float, h: float) -> None:
        self.fmu.doStep(t, h)

    def simulate(self, inputs: np.ndarray, h: float, start: float = 0.0, parameters=None) -> np.ndarray:  # noqa: ANN001
        """Rows like Reference.simulate: inputs[n] set before step n (n = 0 at initialisation), row n after it."""
        self.initialize(inputs[0], start, parameters)
        rows = [self.outputs_now()]
        for n in range(1, len(inputs)):
            self.set_real(self.inputs, inputs[n])
            self.do_step(start + (n - 1) * h, h)
            rows.append(self.outputs_now())
        return np.array(rows)

    def serialised_state(self) -> object:
        """The current FMU state taken through serialising and deserialising it (free it with fmu.freeFMUState)."""
        saved = self.fmu.getFMUState()
        try:
            return self.fmu.deserializeFMUState(self.fmu.serializeFMUState(saved))
        finally:
            self.fmu.freeFMUState(saved)

    def logged(self, status: int) -> list[str]:
        return [m for s, _, m in self.messages if s == status]

    def refused(self, call, *args) -> int:  # noqa: ANN001 (an fmpy method)
        """The status of a call that must fail (FMICallException), or OK/WARNING when it returned normally."""
        try:
            call(*args)
        except FMICallException as err:
            return err.status
        return OK

    def close(self) -> None:
        if not self._open:
            return
        self._open = False
        try:
            self.fmu.terminate()
        except FMICallException:
            pass  # an instance in an error state may refuse to terminate; it is freed all the same
        finally:
            self.fmu.freeInstance()
            _SINKS.pop(self._key, None)
            shutil.rmtree(self._folder, ignore_errors=True)
