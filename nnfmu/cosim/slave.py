"""One FMU instance in fmpy behind a small interface that hides whether it is FMI 2 or FMI 3.

The co-simulation master and the replay of measured data both drive FMUs through this class, by variable name.

FMI 2 log messages come through fmpy's native logger proxy, which formats the message's arguments but holds a single
logger for the whole process. So every instance registers the same module-level logger, and the instance's key in
the callbacks' componentEnvironment routes each message to the instance that logged it.
"""

from __future__ import annotations

import hashlib
import itertools
import os
import shutil
import tempfile
import threading
import weakref
from ctypes import byref, c_void_p
from pathlib import Path
from typing import Sequence

import numpy as np

from nnfmu.cosim.units import PortUnit, port_unit
from nnfmu.stopping import interrupts_deferred

Messages = list[tuple[int, str, str]]  # (status, category, message) as an FMU logged them
_FMI2_SINKS: dict[int, Messages] = {}  # an FMI 2 instance's key (its componentEnvironment) -> its messages
_FMI2_KEYS = itertools.count(1)
_FMI2_LOGGER: object | None = None  # the ctypes logger, made on first use


def _route_fmi2_message(env, instance_name, status, category, message) -> None:  # noqa: ANN001 (ctypes callback)
    sink = _FMI2_SINKS.get(env or 0)
    if sink is not None:
        # pythonfmu logs its fatal errors with a NULL category
        sink.append((status, (category or b"").decode(errors="replace"), (message or b"").decode(errors="replace")))


def _fmi2_logger() -> object:
    """The one ctypes logger every FMI 2 instance registers (made once, kept alive for the process)."""
    global _FMI2_LOGGER
    if _FMI2_LOGGER is None:
        from fmpy.fmi2 import fmi2CallbackLoggerTYPE

        _FMI2_LOGGER = fmi2CallbackLoggerTYPE(_route_fmi2_message)
    return _FMI2_LOGGER


class _Unpacked:
    """FMUs unpacked for instances of this process, by the SHA-256 of the FMU's bytes: the instances of one FMU share
    its folder and so its loaded library (one instance each, as FMI allows unless the FMU is instantiated only once per
    process), and the folder is removed with the last of them. A forked child unpacks its own."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._folders: dict[str, tuple[int, str, int]] = {}  # digest -> (pid, folder, instances using it)

    def acquire(self, path: Path, shared: bool) -> tuple[str, str | None]:
        """(an empty or already unpacked folder for the FMU at `path`, its digest: None when it is not shared)."""
        from fmpy import extract

        if not shared:
            return tempfile.mkdtemp(prefix="nnfmu-fmu-"), None
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        with self._lock:
            pid, folder, count = self._folders.get(digest, (0, "", 0))
            if pid != os.getpid() or not os.path.isdir(folder):
                folder, count = tempfile.mkdtemp(prefix="nnfmu-fmu-"), 0
                try:
                    extract(str(path), unzipdir=folder)
                except BaseException:
                    shutil.rmtree(folder, ignore_errors=True)
                    raise
            self._folders[digest] = (os.getpid(), folder, count + 1)
        return folder, digest

    def release(self, folder: str, digest: str | None) -> None:
        """One instance less on `folder`: removed with its last (at once when it is not shared)."""
        if digest is not None:
            with self._lock:
                pid, held, count = self._folders.get(digest, (0, "", 0))
                if pid == os.getpid() and held == folder and count > 1:
                    self._folders[digest] = (pid, held, count - 1)
                    return
                if held == folder:
                    del self._folders[digest]
        shutil.rmtree(folder, ignore_errors=True)


_UNPACKED = _Unpacked()


def _remove_extracted(folder: str | None, digest: str | None, sinks: dict[int, Messages], key: int) -> None:
    """Forget an instance's FMI 2 message sink and let go of its extracted FMU, if it extracted one (a finalizer:
    holds no instance)."""
    sinks.pop(key, None)
    if folder is not None:
        _UNPACKED.release(folder, digest)


class FmuSlave:
    """An instantiated co-simulation FMU: set inputs and parameters by name, step, read outputs by name.

    The FMU is extracted to a temporary folder, shared by the instances of one FMU in this process (`_Unpacked`), that
    the last of them removes on `close()` (or, for an instance its caller never closed, garbage collection or the
    interpreter's exit); with `unpacked`, `path` is a folder holding an FMU nnfmu
    unpacked itself (the compiled engine's cache), used in place and never removed. `messages` collects what the
    FMU logged as (status, category, message).
    """

    def __init__(
        self, path: str | Path, instance_name: str = "instance", logging_on: bool = False, unpacked: bool = False
    ) -> None:
        from fmpy import extract, read_model_description

        from nnfmu.fmu import read_sample_period
        from nnfmu.safe_zip import check_zip

        self.path = Path(path)
        if not unpacked:
            check_zip(self.path)  # ArchiveError for a zip bomb or a member climbing out, before fmpy reads or extracts
        self.instance_name = instance_name
        self.description = read_model_description(str(self.path))
        self.fmi_version = 3 if self.description.fmiVersion.startswith("3") else 2
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.messages: Messages = []
        self._key = next(_FMI2_KEYS)  # routes an FMI 2 instance's log messages to `messages`
        shared = not self.description.coSimulation.canBeInstantiatedOnlyOncePerProcess
        with interrupts_deferred():  # the folder and its cleanup come together
            self._unzip_dir, digest = (None, None) if unpacked else _UNPACKED.acquire(self.path, shared)
            self._cleanup = weakref.finalize(self, _remove_extracted, self._unzip_dir, digest, _FMI2_SINKS, self._key)
        self.shared_as = digest  # the SHA-256 of the FMU's bytes its instances share a folder by; None: not shared
        try:
            if unpacked:
                directory = str(self.path)
            elif digest is not None:  # unpacked by `_UNPACKED` (now or for another instance)
                directory = self._unzip_dir
            else:
                directory = extract(str(self.path), unzipdir=self._unzip_dir)
            self.directory = Path(directory)
            self.sample_period = read_sample_period(Path(directory) / "modelDescription.xml")
            kwargs = dict(
                guid=self.description.guid,
                unzipDirectory=directory,
                instanceName=instance_name,
                modelIdentifier=self.description.coSimulation.modelIdentifier,
            )
            if self.fmi_version == 2:
                from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions
                from fmpy.logging import addLoggerProxy

                self.fmu = FMU2Slave(**kwargs)
                _FMI2_SINKS[self._key] = self.messages
                callbacks = fmi2CallbackFunctions()
                callbacks.logger = _fmi2_logger()
                callbacks.allocateMemory = defaultCallbacks.allocateMemory
                callbacks.freeMemory = defaultCallbacks.freeMemory
                callbacks.componentEnvironment = c_void_p(self._key)
                addLoggerProxy(byref(callbacks))
                self._callbacks = callbacks  # the FMU keeps a pointer to them: alive as long as the instance
                self.fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)
            else:
                from fmpy.fmi3 import FMU3Slave

                self.fmu = FMU3Slave(**kwargs)
                self.fmu.instantiate(loggingOn=logging_on, logMessage=self._log3)
        except BaseException:
            self._cleanup()  # a failed start leaves no extracted FMU behind
            raise
        self._open = True

    def _log3(self, env, status, category, message) -> None:  # noqa: ANN001 (ctypes callback)
        self.messages.append((status, category.decode(errors="replace"), message.decode(errors="replace")))

    @property
    def takes_input_slopes(self) -> bool:
        """FMI 2 `canInterpolateInputs`: the FMU accepts its inputs' time derivatives for the coming step."""
        return self.fmi_version == 2 and bool(self.description.coSimulation.canInterpolateInputs)

    @property
    def provides_directional_derivatives(self) -> bool:
        """FMI 2 `providesDirectionalDerivative`, FMI 3 `providesDirectionalDerivatives` on the co-simulation element
        (fmpy reads only the FMI 2 spelling, so FMI 3's is read from the model description itself)."""
        if self.fmi_version == 2:
            return bool(self.description.coSimulation.providesDirectionalDerivative)
        from xml.etree import ElementTree

        element = ElementTree.parse(self.directory / "modelDescription.xml").getroot().find("CoSimulation")
        return element is not None and element.get("providesDirectionalDerivatives") == "true"

    @property
    def feedthrough(self) -> bool:
        """Some output depends on an input at a communication point (ModelStructure), so inputs set after a step
        change the outputs there. An output without a `dependencies` attribute depends on every known (FMI 2 and 3),
        as many other tools' FMUs declare them; nnfmu's sampled FMUs list none (`dependencies=""`)."""
        if not self.names("input"):
            return False
        return any(output.dependencies is None or output.dependencies for output in self.description.outputs)

    def names(self, causality: str) -> list[str]:
        """Names of the variables with the given causality ("input", "output", "parameter", ...)."""
        return [v.name for v in self.description.modelVariables if v.causality == causality]

    def unit(self, name: str) -> str:
        variable = self.variables[name]
        return variable.unit or (variable.declaredType.unit if variable.declaredType else "") or ""

    def port_unit(self, name: str) -> PortUnit:
        """The variable's unit, resolved to SI by the FMU's UnitDefinitions or nnfmu's unit table where it can be."""
        return port_unit(self.variables[name], self.description.unitDefinitions or ())

    def value_references(self, names: Sequence[str]) -> list[int]:
        try:
            return [self.variables[n].valueReference for n in names]
        except KeyError as error:
            raise KeyError(f"{self.path}: no variable {error.args[0]!r} (has: {', '.join(self.variables)})") from None

    def set_real(self, names: Sequence[str], values: Sequence[float]) -> None:
        vrs = self.value_references(names)
        values = [float(v) for v in values]
        (self.fmu.setReal if self.fmi_version == 2 else self.fmu.setFloat64)(vrs, values)

    def get_real(self, names: Sequence[str]) -> np.ndarray:
        vrs = self.value_references(names)
        return np.array((self.fmu.getReal if self.fmi_version == 2 else self.fmu.getFloat64)(vrs))

    def real_io(self, inputs: Sequence[str], outputs: Sequence[str]) -> RealIo:
        """Set `inputs` and get `outputs` (Real/Float64) through value references and buffers made once: a replay
        does both every step, and fmpy's `setReal`/`getReal` build both arrays anew on each call."""
        return RealIo(self, self.value_references(inputs), self.value_references(outputs))

    def get_boolean(self, names: Sequence[str]) -> list[bool]:
        return [bool(b) for b in self.fmu.getBoolean(self.value_references(names))]

    def enter_initialization(self, start_time: float) -> None:
        if self.fmi_version == 2:
            self.fmu.setupExperiment(startTime=start_time)
            self.fmu.enterInitializationMode()
        else:
            self.fmu.enterInitializationMode(startTime=start_time)

    def exit_initialization(self) -> None:
        self.fmu.exitInitializationMode()

    def do_step(self, time: float, step: float) -> None:
        self.fmu.doStep(time, step)

    def get_state(self) -> object:
        return self.fmu.getFMUState()

    def set_state(self, state: object) -> None:
        self.fmu.setFMUState(state)

    def free_state(self, state: object) -> None:
        self.fmu.freeFMUState(state)

    def reset(self) -> None:
        """Terminate the run and reset the instance to its state right after instantiation (start values, no
        messages), so that it can run again without loading and instantiating the FMU anew."""
        self.fmu.terminate()
        self.fmu.reset()
        self.messages.clear()  # in place: the FMI 2 logger routes into this very list

    def close(self) -> None:
        """Terminate and free the instance and remove its extracted files (once)."""
        if not self._open:
            return
        self._open = False
        from fmpy.fmi1 import FMICallException

        try:
            self.fmu.terminate()
        except FMICallException:
            pass  # an instance that failed earlier may refuse to terminate; it is freed all the same
        finally:
            self.fmu.freeInstance()
            self._cleanup()

    def __enter__(self) -> "FmuSlave":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RealIo:
    """Fixed Real/Float64 inputs and outputs of one instance, set from and read into numpy buffers; fmpy's low-level
    calls check each status (an FMU's error raises)."""

    def __init__(self, slave: FmuSlave, inputs: list[int], outputs: list[int]) -> None:
        fmu = slave.fmu
        if slave.fmi_version == 2:
            from fmpy.fmi2 import fmi2Real as real
            from fmpy.fmi2 import fmi2ValueReference as reference
        else:
            from fmpy.fmi3 import fmi3Float64 as real
            from fmpy.fmi3 import fmi3ValueReference as reference
        self._in_refs, self._out_refs = (reference * len(inputs))(*inputs), (reference * len(outputs))(*outputs)
        self._in, self._out = (real * len(inputs))(), (real * len(outputs))()
        self._in_view, self._out_view = np.ctypeslib.as_array(self._in), np.ctypeslib.as_array(self._out)
        self._fmu, self._fmi3 = fmu, slave.fmi_version == 3

    def set(self, values: np.ndarray) -> None:
        """Set the inputs to `values` (in the order given)."""
        self._in_view[:] = values
        n = len(self._in)
        if self._fmi3:
            self._fmu.fmi3SetFloat64(self._fmu.component, self._in_refs, n, self._in, n)
        else:
            self._fmu.fmi2SetReal(self._fmu.component, self._in_refs, n, self._in)

    def get(self) -> np.ndarray:
        """The outputs now (a view of the buffer the next `get` overwrites: copy what you keep)."""
        n = len(self._out)
        if self._fmi3:
            self._fmu.fmi3GetFloat64(self._fmu.component, self._out_refs, n, self._out, n)
        else:
            self._fmu.fmi2GetReal(self._fmu.component, self._out_refs, n, self._out)
        return self._out_view
