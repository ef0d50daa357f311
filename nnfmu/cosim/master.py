"""Fixed-step co-simulation master on fmpy for an SSP system: FMUs wired by its connections, and one driven element
whose free inputs read a drive file (a `DriveBinding`: in a road test the vehicle, whose actuators the drive moves).

Time is counted in whole steps: t_n = t0 + n h, so 10 s at 1 ms is exactly 10 000 steps and the last sample is
labelled 10.0 s. Outputs read after the step from t_n belong to t_{n+1} and are labelled so.

Two kinds of FMU, told apart by their model description:
- sampled (nnfmu's networks, most FMUs): the inputs set before doStep(t_n, h) hold over the step; an nnfmu network
  samples at the step end, mapping them to its outputs there. Its outputs change only in doStep.
- with feedthrough at communication points (ModelStructure: outputs depending on inputs; nnfmu's vehicles): the
  inputs are the values at t_n, ramping over the step to the values set at t_{n+1} (FMI 2 `canInterpolateInputs`:
  the slope over the step may be given before it), and outputs at t_{n+1} follow the inputs set there (docs/fmu.md).

One step from t_n, for a coupling signal y (an output wired to an input) with value y_n at t_n:
1. The elements step one after another in `order` (Gauss-Seidel) or all on the same values (Jacobi). A sampled
   element gets, for each input, the freshest value: the t_{n+1} output of an element stepped before it in this
   pass, else y_n (plain) or its estimate for t_{n+1}, 2 y_n - y_{n-1} ('linear' extrapolation); a sampled
   driven element (no feedthrough) holds its inputs over the step, so it gets the mean of y_n and that estimate
   instead. An element with feedthrough already holds its t_n inputs (set in the previous step's refresh) and, where
   it can interpolate and the scheme is not plain, gets their slopes over the step: (estimate - y_n) / h, the
   drive's exactly.
2. Refresh (`refresh`, the default): every element with feedthrough gets its inputs at t_{n+1} (all fresh now: the
   components' outputs, the drive at t_{n+1}) and its outputs are read again, so a vehicle's accelerations see
   the damper force of t_{n+1}, and its state follows the force ramping from t_n to t_{n+1} (trapezoidal rule).
Iterative coupling (`iterations` > 0): every FMU state is saved at t_n; the step is repeated from the saved states
with the t_{n+1} values of the last pass as the estimate until they change by less than `tolerance` (relative to the
signal's peak so far) or `iterations` repeats are spent.

The default (the driven element first, linear extrapolation, refresh) makes one pass per step: the vehicle steps on
the damper force extrapolated linearly, the components sample at t_{n+1} on its motion, and the refresh gives the
vehicle their forces at t_{n+1}: second order in h for motions, forces and accelerations (bench/cosim_coupling.py).

Units: every coupling value is kept in SI where its output's unit converts (`units.py`: the FMU's UnitDefinitions,
else nnfmu's unit table), and converted into each input's unit (a scale and offset per input, applied by the
blocks of `direct.py` and by the C loop alike); connections no conversion joins are refused when the system is
read, before any run. An element with feedthrough that cannot interpolate its inputs holds them over the step
whatever the master estimates: a run with such an element warns (`CosimWarning`) with what it cost.

Cost: per element and pass, one FMI call sets all its inputs, one steps it and one reads all its Real outputs into
the result row (`direct`, buffers and value references prepared once); the refresh adds one set and one get per
element with feedthrough; the drive is interpolated for blocks of steps at once. From Python each such call costs
about 1.5 us of foreign-call overhead, most of a full-vehicle step (9 FMUs); the one-pass schemes of FMI 2 FMUs
therefore run in a compiled C loop (`inner_loop`) over the same buffers with the same arithmetic: bit-identical
results, the full vehicle about 3x faster (bench/cosim.py).
"""

from __future__ import annotations

import math
import time as clock
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from nnfmu.component import same_period
from nnfmu.cosim.binding import DriveBinding, bind_free_inputs
from nnfmu.cosim.direct import ElementTransfers, FmiStatusError, RealBlock, SlopeBlock, Stepper
from nnfmu.cosim.drive_inputs import DriveInputs
from nnfmu.cosim.inner_loop import CompiledLoop, LoopFailure, LoopSystem, library
from nnfmu.cosim.instances import InstancePool
from nnfmu.cosim.port_derivatives import Link, PortDerivatives, exempt_inputs
from nnfmu.cosim.results import CosimResult
from nnfmu.cosim.settings import CosimError, CosimSettings
from nnfmu.cosim.slave import FmuSlave
from nnfmu.cosim.ssp import SystemStructure
from nnfmu.cosim.units import PortUnit, input_conversion, table_unit
from nnfmu.data import Measurement, check_measurement
from nnfmu.data.units import si_unit_of
from nnfmu.stopping import check_stop

STEP_COUNT_TOLERANCE = 1e-9  # relative mismatch allowed between (stop - start) / step and a whole number
DRIVE_BLOCK = 4096  # steps whose drive inputs are interpolated at once (bounds the table's memory on long runs)
Progress = Callable[[int, int], None]  # (steps done, steps in all)
MAX_RESULT_BYTES = 2 * 1024**3  # the result table a run holds in memory: one float64 per step and channel


class CosimWarning(UserWarning):
    """Something about a run the user should know and nothing refuses: inputs an element holds over the step while
    the master's options assume it interpolates them, an output recorded in a unit it did not declare."""


class _Diverged(Exception):
    """A coupling value grew past what a rate over one step can hold; the message names its source."""


def step_count(start: float, stop: float, step: float) -> int:
    """Number of whole steps from start to stop; CosimError when the span is not a whole number of steps."""
    exact = (stop - start) / step
    n = round(exact)
    if n < 1 or abs(n - exact) > STEP_COUNT_TOLERANCE * max(1.0, exact):
        raise CosimError(
            f"the span {start:.9g} s to {stop:.9g} s is not a whole, positive number of "
            f"{step:.9g} s steps ({exact:.9g})"
        )
    return n


def result_table(n_steps: int, channels: int) -> np.ndarray:
    """An empty table for the values at t_0..t_N of `channels` outputs; CosimError naming the limit when it would
    exceed MAX_RESULT_BYTES (a tiny step over a long span), before anything is allocated or run."""
    size = (n_steps + 1) * max(channels, 1) * 8
    if size > MAX_RESULT_BYTES:
        raise CosimError(
            f"{n_steps} steps of {channels} channels make a result of {size / 1024**3:.3g} GiB, more than "
            f"the limit of {MAX_RESULT_BYTES / 1024**3:g} GiB; choose a larger step or an earlier stop"
        )
    return np.empty((n_steps + 1, channels))


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


class _System:
    """The instantiated FMUs, their wiring, and the coupling values at t_n, t_{n-1} and the estimate for t_{n+1}.

    Every Real output of every element has a fixed place in one values row (elements in system order, outputs in
    FMU order): the FMUs write their outputs there, coupling inputs are gathered from there by position, and the
    row is what a result row records. `now`, `before` and the estimates have the same layout.
    """

    def __init__(
        self,
        system: SystemStructure,
        drive: Measurement,
        settings: CosimSettings,
        pool: InstancePool | None = None,
        binding: DriveBinding | None = None,
    ) -> None:
        self.settings = settings
        self.pool = pool
        binding = binding if binding is not None else bind_free_inputs(system)
        self.driven = binding.element
        self.links = [
            _Link(c.start_element, c.start_connector, c.end_element, c.end_connector) for c in system.connections
        ]
        self.parameters = {e.name: dict(e.parameters) for e in system.elements}
        self.slaves: dict[str, FmuSlave] = {}
        try:
            for element in system.elements:
                path = system.fmu_path(element)
                self.slaves[element.name] = (
                    pool.take(path, element.name) if pool is not None else FmuSlave(path, instance_name=element.name)
                )
            connected = {(link.target, link.input) for link in self.links}
            self._check_binding(system.name, binding, connected)
            self.drive_names = list(binding.inputs)
            self.drive = DriveInputs(drive, binding.channels)
            bound = {(binding.element, n) for n in binding.inputs} | exempt_inputs(self.slaves)
            for name, slave in self.slaves.items():
                free = [n for n in slave.names("input") if (name, n) not in connected | bound]
                if free:
                    raise CosimError(
                        f"system {system.name!r}: element {name!r}: input(s) {', '.join(free)} are connected to nothing"
                    )
            self.outputs = {
                name: [n for n in slave.names("output") if slave.variables[n].type in ("Real", "Float64")]
                for name, slave in self.slaves.items()
            }
            self.units = {
                name: {n: slave.port_unit(n) for n in [*slave.names("input"), *self.outputs[name]]}
                for name, slave in self.slaves.items()
            }
            self.elements = self._wire(system.name)
            links = [
                Link(link.source, link.output, link.target, link.input, s, a)
                for link, (s, _, a, _) in zip(self.links, self.link_conversions)
            ]
            self.derivatives = PortDerivatives(self.slaves, links) if settings.port_derivatives else None
        except BaseException:
            self.close(healthy=False)
            raise
        components = [e.name for e in system.elements if e.name != self.driven]
        order = components + [self.driven] if settings.order == "components-first" else [self.driven] + components
        ordered = [self.elements[name] for name in order]
        self.groups = [[element] for element in ordered] if settings.scheme == "gauss-seidel" else [ordered]
        self.refreshed = [e for e in ordered if e.feedthrough and e.inputs is not None] if settings.refresh else []
        self.now = self.values.copy()
        self.before = self.values.copy()
        self.peak = np.zeros(len(self.links))

    def check_periods(self, system_name: str, h: float) -> None:
        """Refuse a step an element cannot honour: one with feedthrough makes its outputs follow inputs set at a
        sample time, so the communication points must be sample times (h a whole multiple of its period T). An
        element without feedthrough honours any h (it evaluates every sample a step reaches)."""
        for name, slave in self.slaves.items():
            period = slave.sample_period
            if period is None or not slave.feedthrough:
                continue
            samples = round(h / period)
            if samples < 1 or not same_period(samples * period, h):
                raise CosimError(
                    f"system {system_name!r}: element {name!r} samples every {period:.9g} s and its "
                    f"outputs follow inputs set at its sample times (feedthrough), so the communication "
                    f"step must be a whole multiple of {period:.9g} s; it is {h:.9g} s"
                )

    def _check_binding(self, system_name: str, binding: DriveBinding, connected: set[tuple[str, str]]) -> None:
        """The bound element exists and every bound input is one of its inputs that no connection reaches."""
        if binding.element not in self.slaves:
            raise CosimError(
                f"system {system_name!r}: the drive binding names element {binding.element!r}, which the "
                f"system does not have ({', '.join(self.slaves)})"
            )
        inputs = set(self.slaves[binding.element].names("input"))
        wrong = [n for n in binding.inputs if n not in inputs or (binding.element, n) in connected]
        if wrong:
            raise CosimError(
                f"system {system_name!r}: element {binding.element!r}: bound input(s) "
                f"{', '.join(wrong)} are not free inputs of its FMU (no such input, or connected)"
            )

    def _wire(self, system_name: str) -> dict[str, ElementTransfers]:
        """The values row, every output's place in it, and each element's prepared transfers."""
        spans, position, start = {}, {}, 0
        for name, outputs in self.outputs.items():
            spans[name] = slice(start, start + len(outputs))
            position.update({(name, output): start + j for j, output in enumerate(outputs)})
            start += len(outputs)
        unknown = [
            f"{link.source}.{link.output} -> {link.target}.{link.input}"
            for link in self.links
            if (link.source, link.output) not in position
        ]
        if unknown:
            raise CosimError(f"system {system_name!r}: connection(s) {'; '.join(unknown)} start at no Real output")
        self.values = np.zeros(start)
        self.link_positions = np.array([position[(link.source, link.output)] for link in self.links], dtype=np.intp)
        elements = {}
        self.link_conversions = [self._link_conversion(system_name, link) for link in self.links]
        self.drive_conversion = self._drive_conversion(system_name)
        for name, slave in self.slaves.items():
            incoming = [link for link in self.links if link.target == name]
            is_driven = name == self.driven
            names = [link.input for link in incoming] + (self.drive_names if is_driven else [])
            inputs = RealBlock(slave, names) if names else None
            buffer = inputs.values if inputs is not None else np.zeros(0)
            conversions = [self.link_conversions[self.links.index(link)][2:] for link in incoming]
            conversions += list(zip(*self.drive_conversion)) if is_driven else []
            slopes = SlopeBlock(slave, names) if names and slave.feedthrough and slave.takes_input_slopes else None
            if inputs is not None:
                scale, offset = (np.array(column, dtype=float) for column in zip(*conversions))
                inputs.convert(scale, offset)
                if slopes is not None and inputs.scale is not None:
                    slopes.scale = scale
            outputs = RealBlock(slave, self.outputs[name], self.values[spans[name]])
            units = [self.units[name][n] for n in self.outputs[name]]
            outputs.convert(np.array([u.scale for u in units]), np.array([u.offset for u in units]))
            elements[name] = ElementTransfers(
                name=name,
                driven_element=is_driven,
                feedthrough=slave.feedthrough,
                sources=np.array([position[(link.source, link.output)] for link in incoming], dtype=np.intp),
                coupled=buffer[: len(incoming)],
                driven=buffer[len(incoming) :],
                inputs=inputs,
                slopes=slopes,
                outputs=outputs,
                stepper=Stepper(slave),
                span=spans[name],
            )
        return elements

    def _link_conversion(self, system_name: str, link: _Link) -> tuple[float, float, float, float]:
        """(s, o, a, b) of a connection: row value = s * output + o, input = a * row value + b; UnitError naming
        the connection, both ports and their units when no conversion joins them."""
        source, target = self.units[link.source][link.output], self.units[link.target][link.input]
        where = f"system {system_name!r}: connection {link.source}.{link.output} -> {link.target}.{link.input}"
        a, b = input_conversion(source, target, where)
        return source.scale, source.offset, a, b

    def _drive_conversion(self, system_name: str) -> tuple[list[float], list[float]]:
        """(a, b) per drive input of the driven element: its value = a * drive value (SI) + b; UnitError naming the
        element, the input, the drive channel and both units when no conversion joins them."""
        scales, offsets = [], []
        for name, channel, unit in zip(self.drive_names, self.drive.names, self.drive.units):
            where = (
                f"system {system_name!r}: element {self.driven!r}, input {name!r} read from drive channel "
                f"{channel!r} of {self.drive.source}"
            )
            a, b = input_conversion(table_unit(unit, channel), self.units[self.driven][name], where, "the drive")
            scales.append(a)
            offsets.append(b)
        return scales, offsets

    def close(self, healthy: bool) -> None:
        """Close the instances, or give them back to the pool (kept for another run only if this one went well)."""
        for slave in self.slaves.values():
            if self.pool is not None:
                self.pool.give(slave, healthy)
            else:
                slave.close()

    def initialise(self, t0: float, drive: np.ndarray) -> None:
        """Initialisation mode: parameters, drive inputs at t0, outputs passed to inputs until settled; then every
        output is read into the values row, and the elements with feedthrough get their inputs at t0 once more."""
        for name, slave in self.slaves.items():
            slave.enter_initialization(t0)
            if self.parameters[name]:
                slave.set_real(list(self.parameters[name]), list(self.parameters[name].values()))
        if self.drive_names:
            scale, offset = (np.array(column) for column in self.drive_conversion)
            self.slaves[self.driven].set_real(self.drive_names, scale * drive + offset)
        for _ in range(len(self.slaves)):
            for link, (s, o, a, b) in zip(self.links, self.link_conversions):
                value = self.slaves[link.source].get_real([link.output])
                self.slaves[link.target].set_real([link.input], a * (s * value + o) + b)
        for slave in self.slaves.values():
            slave.exit_initialization()
        for element in self.elements.values():
            element.outputs.get()
        self.refresh(drive)
        self.now = self.values.copy()
        self.before = self.now.copy()
        self.peak = np.abs(self.now[self.link_positions])

    def estimate(self, first: bool) -> np.ndarray:
        if self.settings.extrapolation == "linear" and not first:
            return 2.0 * self.now - self.before
        return self.now.copy()

    def _set_inputs(
        self, element: ElementTransfers, source: np.ndarray, drive: np.ndarray, end: np.ndarray, h: float
    ) -> None:
        """Before an element's step: a sampled element's inputs from `source` (a sampled driven element: the mean of t_n
        and `source`, and the drive's mean, unless the scheme is plain); an element with feedthrough has its inputs at
        t_n (set by the refresh, else here) and gets their slopes toward `source` and toward the drive's value `end`
        at t_{n+1}."""
        if element.inputs is None:
            return
        if element.feedthrough:
            if not self.refreshed:  # its inputs at t_n are not set yet
                self.now.take(element.sources, out=element.coupled)
                if element.driven_element:
                    element.driven[:] = drive
                element.inputs.set()
            if element.slopes is not None and not self.settings.plain:
                n = len(element.sources)
                element.slopes.values[:n] = (source[element.sources] - self.now[element.sources]) / h
                element.slopes.values[n:] = (end - drive) / h  # not the buffer: a repeat finds t_{n+1} there
                try:
                    element.slopes.set()
                except FmiStatusError as error:
                    raise self._diverged(element, source, h) or error from error
            return
        if element.driven_element and not self.settings.plain:
            element.coupled[:] = 0.5 * (self.now[element.sources] + source[element.sources])
            element.driven[:] = 0.5 * (drive + end)
        else:
            source.take(element.sources, out=element.coupled)
            if element.driven_element:
                element.driven[:] = drive
        element.inputs.set()

    def _diverged(self, element: ElementTransfers, source: np.ndarray, h: float) -> _Diverged | None:
        """When a slope an element refused is not finite, the coupling values it came from, named by their source
        (the element that diverged, not the one that refused its rate)."""
        n = len(element.sources)
        bad = [i for i in range(n) if not math.isfinite(element.slopes.values[i])]
        if not bad:
            return None
        incoming = [link for link in self.links if link.target == element.name]
        described = []
        for i in bad:
            link, slave = incoming[i], self.slaves[incoming[i].source]
            unit = self.units[link.source][link.output].row_unit
            described.append(
                f"{link.source} ({slave.path.name}) output {link.output} went from "
                f"{self.now[element.sources[i]]:.6g} to {source[element.sources[i]]:.6g} {unit} "
                f"over {h:g} s"
            )
        return _Diverged(
            f"the coupling diverged: {'; '.join(described)} (a rate that is not finite, refused by {element.name})"
        )

    def refresh(self, drive: np.ndarray) -> None:
        """Inputs at the current communication point for every element with feedthrough, then its outputs again."""
        for element in self.refreshed:
            self.values.take(element.sources, out=element.coupled)
            if element.driven_element:
                element.driven[:] = drive
            element.inputs.set()
            element.outputs.get()

    def exchange(
        self, t: float, h: float, source: np.ndarray, drive: np.ndarray, end: np.ndarray, fresh: np.ndarray | None
    ) -> None:
        """One pass over the groups: set each element's inputs (`source`: the coupling values to use; `drive` and
        `end`: the drive at t_n and t_{n+1}), step the group, read its outputs into the values row (and into `fresh`,
        if given, for the elements stepped later in the pass); then the refresh at t_{n+1}."""
        for group in self.groups:
            for element in group:
                self._set_inputs(element, source, drive, end, h)
            for element in group:
                element.stepper.step(t, h)
            for element in group:
                element.outputs.get()
                if fresh is not None:
                    fresh[element.span] = self.values[element.span]
        if self.derivatives is not None:
            self.derivatives.update()
        self.refresh(end)

    def step(self, t: float, h: float, first: bool, drive: np.ndarray, end: np.ndarray) -> tuple[int, bool]:
        """One communication step from t with the drive `drive` at t and `end` at t + h; returns (passes taken,
        whether the fixed point was reached). The plain schemes exchange on the values row itself: an element stepped
        later in a Gauss-Seidel pass finds the fresh outputs of those before it there, a Jacobi group sets all before
        any output changes."""
        settings = self.settings
        gauss_seidel = settings.scheme == "gauss-seidel"
        if settings.plain:
            self.exchange(t, h, self.values, drive, end, None)
            self.before, self.now = self.now, self.values.copy()
            return 1, True
        states = {name: slave.get_state() for name, slave in self.slaves.items()} if settings.iterations else {}
        estimate = self.estimate(first)
        converged, passes = settings.iterations == 0, 0
        try:
            for repeat in range(settings.iterations + 1):
                if repeat:
                    for name, state in states.items():
                        self.slaves[name].set_state(state)
                used = estimate
                fresh = used.copy() if gauss_seidel else None
                self.exchange(t, h, fresh if fresh is not None else used, drive, end, fresh)
                passes += 1
                estimate = self.values.copy()
                if settings.iterations:
                    new, old = estimate[self.link_positions], used[self.link_positions]
                    scale = np.maximum(np.maximum(self.peak, np.abs(new)), np.finfo(float).tiny)
                    if np.all(np.abs(new - old) <= settings.tolerance * scale):
                        converged = True
                        break
        finally:
            for name, state in states.items():
                self.slaves[name].free_state(state)
        self.before, self.now = self.now, self.values.copy()
        self.peak = np.maximum(self.peak, np.abs(self.now[self.link_positions]))
        return passes, converged

    def held_inputs(self) -> dict[str, list[int]]:
        """Elements with feedthrough that cannot interpolate their inputs (FMI 2 `canInterpolateInputs` false, or FMI
        3), by name, with the positions in their input block of the inputs they take, when the settings are not plain:
        the master then estimates each input's course over the step, which such an element never sees."""
        if self.settings.plain:
            return {}
        return {
            name: list(range(len(element.inputs.names)))
            for name, element in self.elements.items()
            if element.feedthrough and element.inputs is not None and element.slopes is None
        }

    def holding_warning(self, held: dict[str, list[int]], changes: dict[tuple[str, int], float]) -> str:
        """The warning for `held` inputs, with each input's largest change over one step relative to its peak."""
        h = self.settings.step
        parts = []
        for name, positions in held.items():
            slave = self.slaves[name]
            names = self.elements[name].inputs.names
            moved = ", ".join(f"{names[i]} {100 * changes.get((name, i), math.nan):.2g} %" for i in positions)
            flag = "canInterpolateInputs=false" if slave.fmi_version == 2 else "FMI 3: no input derivatives"
            parts.append(
                f"element {name!r} ({slave.path.name}) cannot interpolate its inputs ({flag}) and holds them over "
                f"each {h:g} s step, so the master's estimate of their course over the step (extrapolation, "
                "slopes) cannot reach inside it; the coupling then costs an error of order h*|du/dt| (first order "
                f"in h): the largest change within one step, of the input's peak: {moved}. Take a smaller step "
                "if that is much, and check the step with `nnfmu cosim --step-study`"
            )
        return "; ".join(parts)

    def input_changes(self, rows: np.ndarray, times: np.ndarray, held: dict[str, list[int]]) -> dict:
        """Per held input (element, position): max |u_{n+1} - u_n| over max |u| along the run (rows: values rows,
        in row units; drive inputs from the drive at `times`)."""
        result: dict[tuple[str, int], float] = {}
        drive = self.drive.table(times) if any(self.elements[n].driven_element for n in held) else None
        for name, positions in held.items():
            element = self.elements[name]
            n = len(element.sources)
            for i in positions:
                u = rows[:, element.sources[i]] if i < n else drive[:, i - n]
                peak = float(np.max(np.abs(u)))
                result[(name, i)] = float(np.max(np.abs(np.diff(u)))) / peak if peak > 0 else 0.0
        return result

    def channels(self) -> list[tuple[str, str]]:
        """(channel name, unit) of every output: the driven element's outputs by name, the others'
        as element_output; in SI where the output's unit converts, else as declared (`result_unit`)."""
        result = []
        self.assumed = []  # channels of outputs that declare no unit, recorded in the SI unit their name says
        for name, outputs in self.outputs.items():
            for output in outputs:
                channel = output if name == self.driven else f"{name}_{output}"
                unit = self.units[name][output]
                result.append((channel, result_unit(unit, channel)))
                if not unit.text and si_unit_of(channel):
                    self.assumed.append(f"{channel} [{si_unit_of(channel)}]")
        names = [c for c, _ in result]
        clashes = sorted({c for c in names if names.count(c) > 1})
        if clashes:
            raise CosimError(f"output channel name(s) {', '.join(clashes)} occur twice; rename an element")
        return result


def result_unit(unit: PortUnit, channel: str) -> str:
    """The unit a result channel is recorded in: its row unit; for an output that declares none, the SI unit its
    name says (`body_acceleration` -> m/s^2, as nnfmu's records name channels), else '1'."""
    if unit.row_unit:
        return unit.row_unit
    return si_unit_of(channel) or "1"


def _check_channel_units(system_name: str, channels: list[tuple[str, str]]) -> None:
    """Before the run: a result a record can hold (a channel named after a quantity in that quantity's SI unit, as
    `save_result` demands), else DataError naming the channel; outputs of known units are in SI by now."""
    units = dict(channels)
    if not units:
        return
    empty = Measurement.uniform(0.0, 1.0, {name: np.zeros(2) for name in units}, units, source=system_name)
    check_measurement(empty, min_samples=2, source=f"system {system_name!r}: result")


def _compiled_loop(parts: _System, settings: CosimSettings) -> CompiledLoop | None:
    """The C loop where the settings allow it and it runs this system; CosimError when 'c' is asked and it cannot."""
    if settings.inner_loop == "python":
        return None
    one_pass = settings.iterations == 0 and not settings.plain
    fmi2 = all(slave.fmi_version == 2 for slave in parts.slaves.values())
    derivatives = parts.derivatives is not None and parts.derivatives.active
    if one_pass and fmi2 and not derivatives and library() is not None:
        return CompiledLoop(
            LoopSystem(
                groups=parts.groups,
                refreshed=parts.refreshed,
                values=parts.values,
                drive_size=len(parts.drive_names),
                linear_extrapolation=settings.extrapolation == "linear",
                gauss_seidel=settings.scheme == "gauss-seidel",
            )
        )
    if settings.inner_loop == "c":
        raise CosimError(
            "inner_loop 'c' needs a one-pass scheme (iterations 0, not plain), FMI 2 FMUs only, a host C compiler "
            "and no port derivatives (CosimSettings.port_derivatives=False)"
        )
    return None


def _loop_error(parts: _System, loop: CompiledLoop, failure: LoopFailure, t: float, h: float) -> Exception:
    """The error the Python loop would have raised for the call the C loop saw fail."""
    element, status = failure.element, failure.status
    if failure.call == "set input slopes":
        parts.now = loop.now
        return parts._diverged(element, loop.source, h) or element.slopes.error(status)
    if failure.call == "step":
        return element.stepper.error(t, h, status)
    if failure.call in ("get outputs", "refresh: get outputs"):
        return element.outputs.get_error(status)
    return element.inputs.set_error(status)


def cosimulate(
    system: SystemStructure,
    drive: Measurement,
    settings: CosimSettings,
    progress: Progress | None = None,
    pool: InstancePool | None = None,
    binding: DriveBinding | None = None,
) -> CosimResult:
    """Run `system` driven by `drive` on fmpy; every FMU output at t_n = t0 + n h, n = 0..N.

    `binding` says which element's free inputs read which drive channels (None: `bind_free_inputs`, the one element
    with free inputs reads the channels of their names).

    A failing FMU call (an FMU refusing a non-finite input when the loop diverges) raises CosimError naming the
    element, the time and what the FMU logged. With a `pool`, the FMU instances come from it and go back to it."""
    stop = settings.stop_time if settings.stop_time is not None else system.stop_time
    parts = _System(system, drive, settings, pool, binding)
    healthy = False
    try:
        h, t0 = settings.step, settings.start_time
        n_steps = step_count(t0, stop, h) if stop is not None else whole_steps(t0, parts.drive.end, h)
        parts.drive.at(t0 + n_steps * h)  # a drive that ends early fails here, before the run
        channels = parts.channels()
        _check_channel_units(system.name, channels)
        if parts.assumed:
            warnings.warn(
                f"system {system.name!r}: output(s) declaring no unit, recorded in the SI unit their name says: "
                f"{', '.join(parts.assumed)}",
                CosimWarning,
                stacklevel=2,
            )
        rows = result_table(n_steps, len(channels))
        parts.check_periods(system.name, h)
        parts.initialise(t0, parts.drive.at(t0))
        if parts.derivatives is not None and parts.derivatives.active:
            parts.derivatives.start()
            parts.refresh(parts.drive.at(t0))
        rows[0] = parts.values
        loop = _compiled_loop(parts, settings)
        if loop is not None:
            loop.start(parts.now, parts.before)
        passes = unconverged = 0
        every = max(1, n_steps // 200)
        started = clock.perf_counter()
        t = t0
        try:
            for first in range(0, n_steps, DRIVE_BLOCK):
                last = min(first + DRIVE_BLOCK, n_steps)
                block = parts.drive.table(t0 + np.arange(first, last + 1) * h)  # drive at t_first .. t_last
                if loop is not None:
                    for start in range(first, last, every):
                        check_stop()  # between calls of the C loop, which no signal interrupts
                        stop = min(start + every, last)
                        failure = loop.steps(start, stop, t0, h, block[start - first :], rows[start + 1 : stop + 1])
                        if failure is not None:
                            t = t0 + failure.step * h
                            raise _loop_error(parts, loop, failure, t, h)
                        passes += stop - start
                        if progress is not None:
                            progress(stop, n_steps)
                    continue
                check_stop()
                for n in range(first, last):
                    t = t0 + n * h
                    taken, converged = parts.step(t, h, n == 0, block[n - first], block[n - first + 1])
                    passes += taken
                    unconverged += not converged
                    rows[n + 1] = parts.values
                    if progress is not None and ((n + 1) % every == 0 or n + 1 == n_steps):
                        progress(n + 1, n_steps)
        except (FmiStatusError, _Diverged) as error:
            raise CosimError(f"system {system.name!r}, step from t = {t:.9g} s: {error}") from error
        elapsed = clock.perf_counter() - started
        healthy = True
    finally:
        parts.close(healthy)
    held = parts.held_inputs()
    if held:
        times = t0 + np.arange(n_steps + 1) * h
        warnings.warn(parts.holding_warning(held, parts.input_changes(rows, times, held)), CosimWarning, stacklevel=2)
    measurement = Measurement.uniform(
        t0,
        h,
        channels={name: rows[:, i] for i, (name, _) in enumerate(channels)},
        units={name: unit for name, unit in channels},
        source=f"co-simulation of {system.name} ({settings.scheme}, h = {h:g} s) on {drive.source}",
        notes={"wall_time_s": f"{elapsed:.3f}", "inner_loop": "C" if loop is not None else "Python"}
        | (
            {"port_derivatives": ", ".join(parts.derivatives.names())}
            if parts.derivatives is not None and parts.derivatives.active
            else {}
        ),
    )
    return CosimResult(measurement, n_steps, passes, unconverged, master="fmpy")
