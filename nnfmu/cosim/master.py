"""Fixed-step co-simulation master on fmpy: one vehicle FMU, component FMUs, drive-file inputs, SSP wiring.

Time is counted in whole steps: t_n = t0 + n h, so 10 s at 1 ms is exactly 10 000 steps and the last sample is
labelled 10.0 s. Outputs read after doStep(t_n, h) belong to t_{n+1} and are labelled so.

How inputs are set before doStep(t_n, h), for a coupling signal y (an output wired to an input):
- y_n is its value at t_n; its value at t_{n+1} is estimated as y_n ('none'), 2 y_n - y_{n-1} ('linear'
  extrapolation), or found by iteration (below). Under Gauss-Seidel an element stepped later in the order uses the
  fresh t_{n+1} values of the elements stepped before it instead of the estimate; under Jacobi all step on estimates.
- A component FMU samples at the step end (an nnfmu component maps the inputs at its sample time to the outputs
  then), so its inputs get the t_{n+1} value.
- The vehicle holds its inputs over the step (zero-order hold into an exact discretisation), so it gets the mean of
  the t_n and t_{n+1} values, the second-order estimate of the step's mean; in the plain scheme (no extrapolation,
  no iteration) it gets the latest value, as any standard master does. Drive inputs follow the same rule with their
  t_{n+1} value known.
- Iterative coupling (`iterations` > 0): every FMU state is saved at t_n; the step is repeated from the saved states
  with the t_{n+1} values of the last pass until they change by less than `tolerance` (relative to the signal's
  peak so far) or `iterations` repeats are spent. Its fixed point holds the vehicle's coupling forces at the mean of
  their values at both step ends (trapezoidal rule), so its error falls with h^2, that of the explicit schemes with h.
- A component's outputs after the step are labelled t_{n+1} but were computed from the inputs it was given: in the
  plain schemes that is the t_n value, so a stateless component's output lags one step; iterated, it is t_{n+1}'s.
  Likewise a vehicle output that feeds through an input (an acceleration) sees the input held over the step.
"""

from __future__ import annotations

import math
import os
import time as clock
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..data import Measurement
from .drive_inputs import DriveInputs
from .results import CosimResult
from .slave import FmuSlave
from .ssp import SystemStructure

SCHEMES = ("gauss-seidel", "jacobi")
ORDERS = ("components-first", "vehicle-first")
EXTRAPOLATIONS = ("none", "linear")
STEP_COUNT_TOLERANCE = 1e-9  # relative mismatch allowed between (stop - start) / step and a whole number
Progress = Callable[[int, int], None]  # (steps done, steps in all)


class CosimError(ValueError):
    """The system or settings cannot be co-simulated; the message names the element, connector or setting."""


@dataclass(frozen=True)
class CosimSettings:
    """Communication `step` [s]; `stop_time` [s] (None: the system's default experiment, else the last whole step
    within the drive).

    `scheme` 'gauss-seidel' (elements one after another in `order`) or 'jacobi' (all on the same values);
    `extrapolation` of coupling signals over a step, 'none' or 'linear'; `iterations`: most repeats of a step for
    strong coupling (0: none), until the t_{n+1} values change by less than `tolerance` of their peak;
    `corner` whose drive channels feed a quarter car's untagged actuator inputs.
    """

    step: float = 1e-3
    stop_time: float | None = None
    start_time: float = 0.0
    scheme: str = "gauss-seidel"
    order: str = "components-first"
    extrapolation: str = "none"
    iterations: int = 0
    tolerance: float = 1e-10
    corner: str = "fl"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.step) and self.step > 0):
            raise CosimError(f"communication step {self.step!r} must be a positive number of seconds")
        for name, value, choices in (("scheme", self.scheme, SCHEMES), ("order", self.order, ORDERS),
                                     ("extrapolation", self.extrapolation, EXTRAPOLATIONS)):
            if value not in choices:
                raise CosimError(f"{name} {value!r} is not one of {', '.join(choices)}")
        if not (isinstance(self.iterations, int) and self.iterations >= 0):
            raise CosimError(f"iterations {self.iterations!r} must be a whole number >= 0")
        if not (self.tolerance > 0):
            raise CosimError(f"tolerance {self.tolerance!r} must be positive")

    @property
    def plain(self) -> bool:
        return self.extrapolation == "none" and self.iterations == 0


def step_count(start: float, stop: float, step: float) -> int:
    """Number of whole steps from start to stop; CosimError when the span is not a whole number of steps."""
    exact = (stop - start) / step
    n = round(exact)
    if n < 1 or abs(n - exact) > STEP_COUNT_TOLERANCE * max(1.0, exact):
        raise CosimError(f"the span {start:.9g} s to {stop:.9g} s is not a whole, positive number of "
                         f"{step:.9g} s steps ({exact:.9g})")
    return n


def whole_steps(start: float, end: float, step: float) -> int:
    """The most whole steps from start that end at or before `end` (a drive's last sample)."""
    n = math.floor((end - start) / step * (1.0 + STEP_COUNT_TOLERANCE))
    if n < 1:
        raise CosimError(f"the drive ends at {end:.9g} s, before one {step:.9g} s step from {start:.9g} s")
    return n


@dataclass(frozen=True)
class _Link:
    """A resolved connection: output `source`.`output` -> input `target`.`input`."""

    source: str
    output: str
    target: str
    input: str


def find_vehicle(system: SystemStructure) -> str:
    """The element whose FMU has unconnected actuator_* inputs (fed from the drive); exactly one must exist."""
    from fmpy import read_model_description

    driven = {(c.end_element, c.end_connector) for c in system.connections}
    candidates = [e.name for e in system.elements
                  if any(v.causality == "input" and v.name.startswith("actuator_") and (e.name, v.name) not in driven
                         for v in read_model_description(str(system.fmu_path(e))).modelVariables)]
    if len(candidates) != 1:
        raise CosimError(f"system {system.name!r}: expected exactly one vehicle element (one with unconnected "
                         f"actuator_* inputs), found {candidates or 'none'}")
    return candidates[0]


class _System:
    """The instantiated FMUs, their wiring, and the coupling values at t_n, t_{n-1} and the estimate for t_{n+1}."""

    def __init__(self, system: SystemStructure, drive: Measurement, settings: CosimSettings) -> None:
        self.settings = settings
        self.vehicle = find_vehicle(system)
        self.links = [_Link(c.start_element, c.start_connector, c.end_element, c.end_connector)
                      for c in system.connections]
        self.parameters = {e.name: dict(e.parameters) for e in system.elements}
        self.slaves: dict[str, FmuSlave] = {}
        try:
            for element in system.elements:
                self.slaves[element.name] = FmuSlave(system.fmu_path(element), instance_name=element.name)
            driven = {(link.target, link.input) for link in self.links}
            vehicle = self.slaves[self.vehicle]
            self.drive_names = [n for n in vehicle.names("input") if (self.vehicle, n) not in driven]
            self.drive = DriveInputs(drive, self.drive_names, settings.corner)
            for name, slave in self.slaves.items():
                free = [n for n in slave.names("input") if (name, n) not in driven and name != self.vehicle]
                if free:
                    raise CosimError(f"system {system.name!r}: element {name!r}: input(s) {', '.join(free)} are "
                                     "connected to nothing")
        except BaseException:
            self.close()
            raise
        components = [e.name for e in system.elements if e.name != self.vehicle]
        order = components + [self.vehicle] if settings.order == "components-first" else [self.vehicle] + components
        self.groups = [[name] for name in order] if settings.scheme == "gauss-seidel" else [order]
        self.outputs = {name: [n for n in slave.names("output") if slave.variables[n].type in ("Real", "Float64")]
                        for name, slave in self.slaves.items()}
        self.now = np.zeros(len(self.links))
        self.before = np.zeros(len(self.links))
        self.peak = np.zeros(len(self.links))

    def close(self) -> None:
        for slave in self.slaves.values():
            slave.close()

    def read_links(self, elements: list[str]) -> dict[int, float]:
        """Current values of the links whose source is one of `elements`, by link index."""
        values: dict[int, float] = {}
        for name in elements:
            indices = [i for i, link in enumerate(self.links) if link.source == name]
            if indices:
                got = self.slaves[name].get_real([self.links[i].output for i in indices])
                values.update(zip(indices, got))
        return values

    def set_inputs(self, name: str, end: np.ndarray, drive_now: np.ndarray, drive_end: np.ndarray) -> None:
        """Set element `name`'s inputs for the step: t_{n+1} values for components, step means for the vehicle."""
        indices = [i for i, link in enumerate(self.links) if link.target == name]
        names = [self.links[i].input for i in indices]
        if name == self.vehicle:
            held = end[indices] if self.settings.plain else 0.5 * (self.now[indices] + end[indices])
            drive = drive_now if self.settings.plain else 0.5 * (drive_now + drive_end)
            names += self.drive_names
            values = np.concatenate([held, drive])
        else:
            values = end[indices]
        if names:
            self.slaves[name].set_real(names, values)

    def initialise(self, t0: float) -> None:
        """Initialisation mode: parameters, drive inputs at t0, outputs passed to inputs until settled."""
        for name, slave in self.slaves.items():
            slave.enter_initialization(t0)
            if self.parameters[name]:
                slave.set_real(list(self.parameters[name]), list(self.parameters[name].values()))
        if self.drive_names:
            self.slaves[self.vehicle].set_real(self.drive_names, self.drive.at(t0))
        for _ in range(len(self.slaves)):
            for link in self.links:
                self.slaves[link.target].set_real([link.input], self.slaves[link.source].get_real([link.output]))
        for slave in self.slaves.values():
            slave.exit_initialization()
        values = self.read_links(list(self.slaves))
        self.now = np.array([values[i] for i in range(len(self.links))])
        self.before = self.now.copy()
        self.peak = np.abs(self.now)

    def estimate(self, first: bool) -> np.ndarray:
        if self.settings.extrapolation == "linear" and not first:
            return 2.0 * self.now - self.before
        return self.now.copy()

    def step(self, t: float, h: float, first: bool, drive_now: np.ndarray, drive_end: np.ndarray) -> tuple[int, bool]:
        """One communication step from t; returns (passes taken, whether the fixed point was reached)."""
        settings = self.settings
        states = {name: slave.get_state() for name, slave in self.slaves.items()} if settings.iterations else {}
        end = self.estimate(first)
        converged, passes = settings.iterations == 0, 0
        try:
            for repeat in range(settings.iterations + 1):
                if repeat:
                    for name, state in states.items():
                        self.slaves[name].set_state(state)
                used, fresh = end.copy(), end.copy()
                for group in self.groups:
                    for name in group:
                        self.set_inputs(name, fresh if settings.scheme == "gauss-seidel" else used,
                                        drive_now, drive_end)
                    for name in group:
                        self.slaves[name].do_step(t, h)
                    for index, value in self.read_links(group).items():
                        fresh[index] = value
                passes += 1
                end = fresh
                if settings.iterations:
                    scale = np.maximum(np.maximum(self.peak, np.abs(fresh)), np.finfo(float).tiny)
                    if np.all(np.abs(fresh - used) <= settings.tolerance * scale):
                        converged = True
                        break
        finally:
            for name, state in states.items():
                self.slaves[name].free_state(state)
        self.before, self.now = self.now, end
        self.peak = np.maximum(self.peak, np.abs(end))
        return passes, converged

    def output_row(self) -> np.ndarray:
        return np.concatenate([self.slaves[name].get_real(outputs) for name, outputs in self.outputs.items()])

    def channels(self) -> list[tuple[str, str]]:
        """(channel name, unit) of every output: vehicle outputs by name, component outputs as element_output."""
        result = []
        for name, outputs in self.outputs.items():
            for output in outputs:
                channel = output if name == self.vehicle else f"{name}_{output}"
                result.append((channel, self.slaves[name].unit(output) or "1"))
        names = [c for c, _ in result]
        clashes = sorted({c for c in names if names.count(c) > 1})
        if clashes:
            raise CosimError(f"output channel name(s) {', '.join(clashes)} occur twice; rename an element")
        return result


def cosimulate(system: SystemStructure, drive: Measurement, settings: CosimSettings,
               progress: Progress | None = None) -> CosimResult:
    """Run `system` driven by `drive` on fmpy; every FMU output at t_n = t0 + n h, n = 0..N."""
    stop = settings.stop_time if settings.stop_time is not None else system.stop_time
    parts = _System(system, drive, settings)
    try:
        h, t0 = settings.step, settings.start_time
        n_steps = step_count(t0, stop, h) if stop is not None else whole_steps(t0, parts.drive.end, h)
        channels = parts.channels()
        rows = np.empty((n_steps + 1, len(channels)))
        parts.initialise(t0)
        rows[0] = parts.output_row()
        passes = unconverged = 0
        every = max(1, n_steps // 200)
        drive_end = parts.drive.at(t0)
        started = clock.perf_counter()
        for n in range(n_steps):
            t, t_next = t0 + n * h, t0 + (n + 1) * h
            drive_now, drive_end = drive_end, parts.drive.at(t_next)
            taken, converged = parts.step(t, h, n == 0, drive_now, drive_end)
            passes += taken
            unconverged += not converged
            rows[n + 1] = parts.output_row()
            if progress is not None and ((n + 1) % every == 0 or n + 1 == n_steps):
                progress(n + 1, n_steps)
        elapsed = clock.perf_counter() - started
    finally:
        parts.close()
    measurement = Measurement(
        time=t0 + np.arange(n_steps + 1) * h,
        channels={name: rows[:, i] for i, (name, _) in enumerate(channels)},
        units={name: unit for name, unit in channels},
        source=f"co-simulation of {system.name} ({settings.scheme}, h = {h:g} s) on {drive.source}",
        notes={"wall_time_s": f"{elapsed:.3f}"},
    )
    return CosimResult(measurement, n_steps, passes, unconverged, master="fmpy")


def run_cosim(ssd_path: str | os.PathLike[str], drive_path: str | os.PathLike[str], settings: CosimSettings,
              out_path: str | os.PathLike[str] | None = None, progress: Progress | None = None) -> CosimResult:
    """`nnfmu cosim`: read the system (.ssd, folder or .ssp) and the drive file, co-simulate, write the result."""
    from ..vehicle.drive import read_drive
    from .results import save_result
    from .ssp import open_system

    drive = read_drive(drive_path)
    with open_system(ssd_path) as system:
        result = cosimulate(system, drive, settings, progress)
    if out_path is not None:
        save_result(result, out_path)
    return result
