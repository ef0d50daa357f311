"""The FMU semantics both pythonfmu slaves share: sample clock, graph evaluation, output filter, envelope, refusals.

`SampledComponent` runs `resources/model.onnx` with onnxruntime as docs/architecture.md specifies, reading the ports,
states, sample period and envelope from the ONNX metadata and the FMU variables from `resources/variables.json`.
The FMI 2 slave (`fmi2_slave.py`, pythonfmu) and the FMI 3 slave (`fmi3_slave.py`, pythonfmu3) only translate FMI
calls to it; `SlaveBridge` is their version-independent half. This file is shipped unchanged beside them in every
pythonfmu FMU and runs in the importing tool's Python: it needs numpy and onnxruntime there and must not import
nnfmu or pythonfmu. It never raises after construction (both runtimes turn an exception into a fatal error): a bad
call is reported and refused instead.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

import numpy as np
import onnxruntime as ort

COMPONENT_KEY = "nnfmu.component"
MODEL_FILE = "model.onnx"
VARIABLES_FILE = "variables.json"
REACHED = 1e-6  # a sample time within REACHED * period of the step end counts as reached
# one doStep's work is bounded (each sample is an onnxruntime call of some microseconds): more samples are refused
MAX_SAMPLES_PER_STEP = 100_000
STATE_KEY = "FMU state"  # the entry of the refused values a refused FMU state makes
UNREADABLE = "unreadable"  # the one field of what `from_bytes` returns for bytes that are no JSON object
STATE_FIELDS = (
    "inputs",
    "raw",
    "outputs",
    "parameters",
    "graph_state",
    "graph_state_before",
    "outside",
    "refused",
    "extrapolating",
    "t_start",
    "time",
    "elapsed",
    "sample",
    "evaluated_at",
)
_ORT_DTYPES = {"tensor(double)": np.float64, "tensor(float)": np.float32}  # graph input types the slave feeds

LOG_CATEGORIES = {  # the FMI log categories of the messages reported here, for the slaves' model descriptions
    "logStatusWarning": "an input left the training envelope, once per excursion",
    "logStatusError": "refused calls and values",
}

Severity = Literal["warning", "error"]
Report = Callable[[str, Severity], None]  # how a slave passes a message to its FMI logger


def _finite(value: Any) -> bool:
    """A finite JSON number (a bool is none)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _session(model: Path) -> ort.InferenceSession:
    """A single-threaded onnxruntime session (the graphs are tiny; threads would only add latency)."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    return ort.InferenceSession(str(model), options, providers=["CPUExecutionProvider"])


def _envelope(port: dict[str, Any]) -> tuple[float, float]:
    """The training range [min, max] of an input port (unbounded where the component description gives none)."""
    lo = -math.inf if port.get("min") is None else port["min"]
    hi = math.inf if port.get("max") is None else port["max"]
    return lo, hi


def _compensated_sum(total: float, carry: float, step: float) -> tuple[float, float]:
    """total + step with Kahan's compensation: after n steps of h the sum is n h to the last bit or so, which decides
    where between two samples a communication point falls."""
    y = step - carry
    new_total = total + y
    return new_total, (new_total - total) - y


def _static_shape(node_arg: Any) -> tuple[int, ...]:
    """Shape of a graph tensor with symbolic or unknown dimensions (a batch) taken as 1."""
    return tuple(d if isinstance(d, int) and d > 0 else 1 for d in node_arg.shape)


class _Tensor:
    """A graph input buffer: its name, dtype and shape; filled element-wise from ports or a state vector."""

    def __init__(self, node_arg: Any) -> None:
        self.name = node_arg.name
        self.dtype = _ORT_DTYPES.get(node_arg.type)
        self.shape = _static_shape(node_arg)

    def zeros(self) -> np.ndarray:
        return np.zeros(self.shape, dtype=self.dtype)


class SampledComponent:
    """One FMU instance's model data and behaviour: samples at the sample period, outputs between them from the
    interpolated graph state, output low-pass and gain, envelope flag, refused non-finite values, and a
    JSON-serialisable state."""

    def __init__(self, resources: Path, report: Report) -> None:
        """Load the graph and the variable table from `resources`; ValueError when they do not fit each other."""
        self._report = report
        self._session = _session(resources / MODEL_FILE)
        component = json.loads(self._session.get_modelmeta().custom_metadata_map[COMPONENT_KEY])
        table = json.loads((resources / VARIABLES_FILE).read_text(encoding="utf-8"))
        self.description: str | None = component.get("description") or None
        self.variables: list[dict[str, Any]] = sorted(table["variables"], key=lambda v: v["value_reference"])
        self._by_vr = {v["value_reference"]: v for v in self.variables}

        self._in_ports = component["inputs"]
        self._out_ports = component["outputs"]
        self._states = component.get("states", [])
        self._period: float | None = component.get("sample_period")
        self._tensors = {a.name: _Tensor(a) for a in self._session.get_inputs()}
        self._output_names = [o.name for o in self._session.get_outputs()]
        self._check_tensors()

        self._inputs = [0.0] * len(self._in_ports)
        self._raw = [0.0] * len(self._out_ports)  # graph outputs of the latest sample
        self._outputs = [0.0] * len(self._out_ports)  # after gain and filter: what the FMU reports
        self._parameters = {v["name"]: float(v["start"]) for v in self.variables if v["causality"] == "parameter"}
        self._graph_state = {s["input"]: [float(v) for v in s["initial"]] for s in self._states}
        self._graph_state_before = {k: list(v) for k, v in self._graph_state.items()}  # the latest sample's own
        self._outside = [False] * len(self._in_ports)
        self._refused: dict[str, str] = {}  # variable name -> why its last value was refused
        self._extrapolating = False
        self._t_start: float | None = None  # set by `start`, else by the first step
        self._time = 0.0
        self._sample = -1  # index of the latest evaluated sample; -1 before initialisation ends
        # [s] since the start, when the outputs were last evaluated (the output filter runs from there)
        self._evaluated_at = 0.0
        # [s] the step sizes summed since the start, and what the sum lost (Kahan): samples are counted against it,
        # never against the absolute time, so a large start time (1e300 s) loses none; it also says where between
        # two samples a communication point falls
        self._elapsed = (0.0, 0.0)
        self._preview: tuple[list[float], bool] | None = None  # sample 0 from the current values, until one changes

    def _check_tensors(self) -> None:
        """Every port and state must name a floating-point graph tensor and an element inside it."""
        outputs = {o.name: _static_shape(o) for o in self._session.get_outputs()}
        inputs = {name: t.shape for name, t in self._tensors.items()}
        for kind, ports, shapes in (("input", self._in_ports, inputs), ("output", self._out_ports, outputs)):
            for port in ports:
                shape = shapes.get(port["tensor"])
                if shape is None or not 0 <= port["index"] < math.prod(shape):
                    raise ValueError(
                        f"{kind} port {port['name']!r} names element {port['index']} of tensor "
                        f"{port['tensor']!r}, which the graph's {kind}s {sorted(shapes)} do not hold"
                    )
        for state in self._states:
            for name, shapes in ((state["input"], inputs), (state["output"], outputs)):
                if name not in shapes or math.prod(shapes[name]) != len(state["initial"]):
                    raise ValueError(
                        f"state tensor {name!r} of {len(state['initial'])} elements is not in the "
                        f"graph (tensors: {sorted(shapes)})"
                    )
        for tensor in self._session.get_inputs():
            if tensor.type not in _ORT_DTYPES:
                raise ValueError(f"graph input {tensor.name!r} is {tensor.type}; only float and double are supported")

    # ----- variables -------------------------------------------------------------------------------------------------
    def read(self, vr: int, var_type: str, function: str) -> float | bool:
        """The value of variable `vr` of table type `var_type` ("Real" or "Boolean"); a mismatch is reported. Before
        initialisation ends, outputs read the preview of sample 0."""
        var = self._by_vr.get(vr)
        if var is None or var["type"] != var_type:
            self._report(f"{function}: value reference {vr} is not a {var_type} variable", "error")
            return False if var_type == "Boolean" else 0.0
        causality = var["causality"]
        if causality == "input":
            return self._inputs[var["port_index"]]
        if causality == "parameter":
            return self._parameters[var["name"]]
        if causality == "independent":
            return self._time
        outputs, extrapolating = self._sample_0_preview() if self._sample < 0 else (self._outputs, self._extrapolating)
        return outputs[var["port_index"]] if var_type == "Real" else extrapolating

    def write(self, vr: int, value: Any, var_type: str, function: str) -> None:
        """Set an input or parameter. A NaN/Inf (or negative cut-off) is refused: the old value is kept, the message
        reported, and steps are refused until a valid value is set. Parameters are fixed once initialisation ends."""
        var = self._by_vr.get(vr)
        if var is None or var["type"] != var_type or var["causality"] not in ("input", "parameter"):
            self._report(f"{function}: value reference {vr} is not a settable {var_type} variable", "error")
            return
        name = var["name"]
        if var["causality"] == "parameter" and self._sample >= 0:
            self._report(
                f"{function}: parameter {name!r} is fixed: it can only be set before initialisation ends; "
                f"it keeps {self._parameters[name]!r}",
                "error",
            )
            return
        value = float(value)
        if not math.isfinite(value) or (name == "filter_cutoff" and value < 0.0):
            self._refused[name] = f"{name!r} was set to {value!r}"
            self._report(
                f"{function}: refused {value!r} for {name!r} (value reference {vr}) at t = {self._time!r} s; "
                f"it keeps {self.read(vr, var_type, function)!r} and doStep is refused until a valid value "
                f"is set",
                "error",
            )
            return
        self._refused.pop(name, None)
        self._preview = None
        if var["causality"] == "input":
            self._inputs[var["port_index"]] = value
        else:
            self._parameters[name] = value

    # ----- time ------------------------------------------------------------------------------------------------------
    def start(self, start_time: float) -> None:
        """Count samples from `start_time` (the FMI 2 start time; pythonfmu3 does not pass FMI 3's to the slave); a
        start time that is not finite is refused (initialisation then ends in an error), as the native FMU does."""
        if not _finite(start_time):
            self._refused["start time"] = f"start time {start_time!r} s is not finite"
            self._report(f"setupExperiment: start time {start_time!r} s is not finite", "error")
            return
        self._refused.pop("start time", None)
        self._t_start = float(start_time)
        self._time = float(start_time)
        self._elapsed = (0.0, 0.0)

    def initialise(self) -> bool:
        """Evaluate sample 0 with the inputs set during initialisation; False (reported) while a value is refused."""
        if self._refused:
            self._report(f"initialisation ends with refused values: {'; '.join(self._refused.values())}", "error")
            return False
        return self._evaluate(self._period or 0.0, self._t_start or 0.0)

    def step(self, current_time: float, step_size: float) -> bool:
        """Evaluate every sample t_k with current_time < t_k <= current_time + step_size; False refuses the step.
        Without a start time (FMI 3), the first step's communication point is the start time."""
        if self._sample < 0:
            self._report(
                f"doStep at t = {current_time!r} s refused: the FMU is not initialised (call "
                "exitInitializationMode first)",
                "error",
            )
            return False
        if self._refused:
            self._report(f"doStep at t = {current_time!r} s refused: {'; '.join(self._refused.values())}", "error")
            return False
        if self._t_start is None and math.isfinite(current_time):
            self.start(current_time)
        scale = max(self._period or 0.0, step_size, abs(current_time), 1e-300)
        if not step_size > 0.0 or not abs(current_time - self._time) <= REACHED * scale:
            self._report(
                f"doStep({current_time!r}, {step_size!r}): expected a positive step from the last "
                f"communication point {self._time!r} s",
                "error",
            )
            return False
        end = current_time + step_size
        elapsed = _compensated_sum(*self._elapsed, step_size)
        if self._period is None:
            if not self._evaluate(step_size, end):
                return False
        else:
            t_start = self._t_start if self._t_start is not None else 0.0
            due = elapsed[0] / self._period + REACHED - self._sample
            if not due <= MAX_SAMPLES_PER_STEP:  # also for an infinite or NaN count
                self._report(
                    f"doStep({current_time!r}, {step_size!r}) refused: it spans {due:.4g} samples of "
                    f"{self._period!r} s, more than the {MAX_SAMPLES_PER_STEP} one step may evaluate; take "
                    "shorter steps",
                    "error",
                )
                return False
            for _ in range(max(0, math.floor(due))):
                offset = (self._sample + 1) * self._period  # times since the start: no rounding of large t_start
                if not self._evaluate(offset - self._evaluated_at, t_start + offset):
                    return False
                self._evaluated_at = offset
            alpha = (elapsed[0] - self._sample * self._period) / self._period
            if alpha > REACHED:
                if not self._evaluate_between(min(alpha, 1.0), elapsed[0] - self._evaluated_at):
                    return False
                self._evaluated_at = elapsed[0]
        self._time = end
        self._elapsed = elapsed
        return True

    # ----- one sample ------------------------------------------------------------------------------------------------
    def _run_graph(
        self, graph_state: dict[str, list[float]] | None = None
    ) -> tuple[dict[str, list[float]], list[float]]:
        """The graph's next state and raw outputs from the current inputs and `graph_state` (default: the current
        one); nothing is changed."""
        graph_state = self._graph_state if graph_state is None else graph_state
        feeds = {name: t.zeros() for name, t in self._tensors.items()}
        for port, value in zip(self._in_ports, self._inputs):
            feeds[port["tensor"]].reshape(-1)[port["index"]] = value
        for state in self._states:
            feeds[state["input"]].reshape(-1)[:] = graph_state[state["input"]]
        results = dict(zip(self._output_names, self._session.run(self._output_names, feeds)))
        graph_state = {s["input"]: [float(v) for v in np.ravel(results[s["output"]])] for s in self._states}
        raw = [float(np.ravel(results[p["tensor"]])[p["index"]]) for p in self._out_ports]
        return graph_state, raw

    def _sample_0_preview(self) -> tuple[list[float], bool]:
        """Outputs and envelope flag of sample 0 as ending initialisation now would evaluate them (docs/fmu.md: read
        in Initialization Mode), without advancing state or logging; kept until an input, parameter or state is set."""
        if self._preview is None:
            _, raw = self._run_graph()
            gain = self._parameters["output_gain"]
            outside = any(
                not lo <= value <= hi for (lo, hi), value in zip(map(_envelope, self._in_ports), self._inputs)
            )
            self._preview = ([gain * u for u in raw], outside)
        return self._preview

    def _evaluate(self, period: float, t_sample: float) -> bool:
        """Run the graph for the next sample, advance its state, filter the outputs (over `period` seconds) and check
        the envelope; a non-finite state or output discards the sample (reported, False), as the native FMU does."""
        graph_state, raw = self._run_graph()
        k = self._sample + 1
        for name, values in graph_state.items():
            if not all(map(math.isfinite, values)):
                self._report(f"state tensor {name!r} of sample {k} is not finite; the sample is discarded", "error")
                return False
        outputs = self._filtered(raw, period, first=k == 0)
        if not self._finite_outputs(outputs, raw, f"sample {k}"):
            return False
        self._graph_state_before = self._graph_state
        self._graph_state, self._raw, self._outputs[:] = graph_state, raw, outputs
        self._sample = k
        self._check_envelope(t_sample)
        return True

    def _evaluate_between(self, alpha: float, period: float) -> bool:
        """Outputs at a communication point a fraction `alpha` of the period after the latest sample: the graph on
        the current inputs and the state interpolated between the latest sample's own and the one after it; only
        the output filter (over `period` seconds) advances (docs/fmu.md). Non-finite outputs: reported, False."""
        between = {
            name: [(1.0 - alpha) * b + alpha * a for b, a in zip(self._graph_state_before[name], after)]
            for name, after in self._graph_state.items()
        }
        _, raw = self._run_graph(between)
        outputs = self._filtered(raw, period)
        if not self._finite_outputs(outputs, raw, f"the communication point after sample {self._sample}"):
            return False
        self._raw, self._outputs[:] = raw, outputs
        return True

    def _finite_outputs(self, outputs: list[float], raw: list[float], where: str) -> bool:
        """True when every output is finite, else reports the first that is not (the evaluation is discarded)."""
        for port, value, u in zip(self._out_ports, outputs, raw):
            if not math.isfinite(value):
                self._report(
                    f"output {port['name']!r} of {where} is {value!r} (network {u!r}, output_gain "
                    f"{self._parameters['output_gain']!r}); the evaluation is discarded",
                    "error",
                )
                return False
        return True

    def _filtered(self, raw: list[float], period: float, first: bool = False) -> list[float]:
        """The low-passed, gained outputs over `period` seconds: y = y_prev + a (g u - y_prev), y_0 = g u_0 at the
        `first` sample."""
        gain, cutoff = self._parameters["output_gain"], self._parameters["filter_cutoff"]
        gained = [gain * u for u in raw]
        if first or cutoff == 0.0:
            return gained
        a = 1.0 - math.exp(-2.0 * math.pi * cutoff * period)
        return [y + a * (u - y) for y, u in zip(self._outputs, gained)]

    def _check_envelope(self, t_sample: float) -> None:
        """Flag inputs outside the training envelope; report one warning when an input leaves it."""
        for i, (port, value) in enumerate(zip(self._in_ports, self._inputs)):
            lo, hi = _envelope(port)
            outside = not lo <= value <= hi
            if outside and not self._outside[i]:
                unit = port.get("unit", "")
                self._report(
                    f"input {port['name']!r} = {value!r} {unit} left the training envelope [{lo!r}, {hi!r}] "
                    f"{unit} at sample {self._sample} (t = {t_sample!r} s); outputs are extrapolated",
                    "warning",
                )
            self._outside[i] = outside
        self._extrapolating = any(self._outside)

    # ----- FMU state -------------------------------------------------------------------------------------------------
    def save(self) -> dict[str, Any]:
        """A JSON-serialisable copy of everything that evolves: inputs, parameters, graph and filter state, clock."""
        return {
            "inputs": list(self._inputs),
            "raw": list(self._raw),
            "outputs": list(self._outputs),
            "parameters": dict(self._parameters),
            "graph_state": {k: list(v) for k, v in self._graph_state.items()},
            "graph_state_before": {k: list(v) for k, v in self._graph_state_before.items()},
            "outside": list(self._outside),
            "refused": dict(self._refused),
            "extrapolating": self._extrapolating,
            "t_start": self._t_start,
            "time": self._time,
            "sample": self._sample,
            "evaluated_at": self._evaluated_at,
            "elapsed": list(self._elapsed),
        }

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from a state `save` returned (in this or another instance of the same FMU). A state this FMU
        could not continue from (garbage, forged, or another FMU's) is reported naming the field and refused: the
        instance keeps its own state and refuses to step until a valid state is set. (The runtimes give these
        calls no error status: an exception would be fatal, and pythonfmu corrupts its heap freeing such an
        instance.)"""
        try:
            self._check_state(state)
        except ValueError as error:
            self._report(str(error), "error")
            self._refused[STATE_KEY] = str(error)
            return
        self._inputs[:] = state["inputs"]
        self._raw[:] = state["raw"]
        self._outputs[:] = state["outputs"]
        self._parameters = {k: float(v) for k, v in state["parameters"].items()}
        self._graph_state = {k: list(v) for k, v in state["graph_state"].items()}
        self._graph_state_before = {k: list(v) for k, v in state["graph_state_before"].items()}
        self._outside[:] = state["outside"]
        self._refused = dict(state["refused"])
        self._extrapolating = bool(state["extrapolating"])
        self._t_start = None if state["t_start"] is None else float(state["t_start"])
        self._time = float(state["time"])
        self._sample = int(state["sample"])
        self._evaluated_at = float(state["evaluated_at"])
        self._elapsed = (float(state["elapsed"][0]), float(state["elapsed"][1]))
        self._preview = None

    def _check_state(self, state: Any) -> None:
        """ValueError naming the first field of a deserialised state that does not fit this FMU."""

        def refuse(reason: str) -> None:
            raise ValueError(f"FMU state refused: {reason}")

        if not isinstance(state, dict):
            refuse(f"it is a JSON {type(state).__name__}, expected an object")
        if UNREADABLE in state:
            refuse(f"its bytes are no JSON object ({state[UNREADABLE]})")
        for key in STATE_FIELDS:
            if key not in state:
                refuse(f"{key!r} is missing")
        sizes = {
            "inputs": len(self._in_ports),
            "raw": len(self._out_ports),
            "outputs": len(self._out_ports),
            "outside": len(self._in_ports),
        }
        for key, size in sizes.items():
            values = state[key]
            if not isinstance(values, list) or len(values) != size:
                refuse(
                    f"{key!r} holds {len(values) if isinstance(values, list) else repr(values)} values, expected {size}"
                )
            for value in values:
                if not (isinstance(value, bool) if key == "outside" else _finite(value)):
                    refuse(f"{key!r} holds {value!r}")
        for key, expected in (
            ("parameters", {k: 1 for k in self._parameters}),
            ("graph_state", {k: len(v) for k, v in self._graph_state.items()}),
            ("graph_state_before", {k: len(v) for k, v in self._graph_state.items()}),
        ):
            given = state[key]
            if not isinstance(given, dict) or set(given) != set(expected):
                refuse(
                    f"{key!r} names {sorted(given) if isinstance(given, dict) else repr(given)}, expected "
                    f"{sorted(expected)}"
                )
            for name, value in given.items():
                values = value if key.startswith("graph_state") else [value]
                if not isinstance(values, list) or len(values) != expected[name] or not all(map(_finite, values)):
                    refuse(f"{key!r}: {name!r} is {value!r}")
        if not isinstance(state["refused"], dict) or not all(isinstance(v, str) for v in state["refused"].values()):
            refuse(f"'refused' is {state['refused']!r}")
        if not isinstance(state["extrapolating"], bool):
            refuse(f"'extrapolating' is {state['extrapolating']!r}")
        if state["t_start"] is not None and not _finite(state["t_start"]):
            refuse(f"'t_start' is {state['t_start']!r}")
        for key in ("time", "evaluated_at"):
            if not _finite(state[key]):
                refuse(f"{key!r} is {state[key]!r}")
        elapsed = state["elapsed"]
        if not isinstance(elapsed, list) or len(elapsed) != 2 or not all(map(_finite, elapsed)) or elapsed[0] < 0:
            refuse(f"'elapsed' is {elapsed!r}")
        sample = state["sample"]
        if isinstance(sample, bool) or not isinstance(sample, int) or sample < -1:
            refuse(f"'sample' is {sample!r}")

    @staticmethod
    def to_bytes(state: dict[str, Any]) -> bytes:
        return json.dumps(state, allow_nan=False).encode("utf-8")

    @staticmethod
    def from_bytes(data: bytes) -> dict[str, Any]:
        """The state in `data`; bytes that are no JSON object give a state naming why, which `restore` refuses (an
        exception here would be fatal)."""
        try:
            state = json.loads(bytes(data).decode("utf-8"))
        except (ValueError, RecursionError) as error:
            return {UNREADABLE: str(error)[:200]}
        return state if isinstance(state, dict) else {UNREADABLE: f"a JSON {type(state).__name__}"}


class SlaveBridge:
    """The half of the FMI 2 and FMI 3 slaves that does not depend on the FMI version, mixed in before the runtime's
    slave class: builds the `SampledComponent`, registers the variable table and forwards Booleans and FMU state.

    A slave supplies `runtime_name`, `_scalar(var, description)` (the runtime's variable object for one table entry)
    and `_report(message, severity)`.
    """

    log_categories = LOG_CATEGORIES
    runtime_name = ""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._core = SampledComponent(Path(self.resources), self._report)
        self.description = self._core.description
        for var in self._core.variables:
            self._register(var)

    def _register(self, var: dict[str, Any]) -> None:
        """Register one table entry (in value-reference order, so the runtime assigns the same reference)."""
        scalar = self._scalar(var, var["description"] or None)
        self.register_variable(scalar, nested=False)
        if scalar.value_reference != var["value_reference"]:
            raise ValueError(
                f"{var['name']!r}: {self.runtime_name} gave value reference {scalar.value_reference}, "
                f"the variable table says {var['value_reference']}"
            )

    def exit_initialization_mode(self) -> None:
        self._core.initialise()

    def _read_reals(self, vrs: list[int], function: str) -> list[float]:
        return [self._core.read(vr, "Real", function) for vr in vrs]

    def _write_reals(self, vrs: list[int], values: list[float], function: str) -> None:
        for vr, value in zip(vrs, values):
            self._core.write(vr, value, "Real", function)

    def get_boolean(self, vrs: list[int]) -> list[bool]:
        return [bool(self._core.read(vr, "Boolean", "getBoolean")) for vr in vrs]

    def set_boolean(self, vrs: list[int], values: list[bool]) -> None:
        for vr, value in zip(vrs, values):
            self._core.write(vr, value, "Boolean", "setBoolean")

    def _get_fmu_state(self) -> dict[str, Any]:
        return self._core.save()

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        self._core.restore(state)

    _fmu_state_to_bytes = staticmethod(SampledComponent.to_bytes)
    _fmu_state_from_bytes = staticmethod(SampledComponent.from_bytes)
