"""Feature specs: which input channels a component model sees, at which sample delays, plus derived channels.

A `FeatureSpec` is the single definition of a model's inputs. It computes the feature matrix for training
(`features`, numpy) and emits the same computation as ONNX nodes for the step graph (`emit`), side by side, so the
exported graph reproduces training exactly: sample by sample from the initial state (a component at rest, every
delayed value and filter state 0), or, with `relaxed_start`, from the state the first sample's inputs would have
held forever (every delayed value, filter and play operator at that input: a bushing in a car starts deflected
under the car's weight, its rubber relaxed and its friction anchored there, not moved there from zero).

Adding a derived feature is a checklist: a frozen dataclass subclass of `Derived` (numpy `compute` and ONNX `emit`),
an entry in `DERIVED_KINDS`, and a test in tests/models/test_features.py comparing it with the step graph.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, fields
from typing import Any, ClassVar, Protocol

import numpy as np
from scipy.signal import lfilter

from nnfmu.errors import SettingsError


class NodeSink(Protocol):
    """What `emit` needs from a graph builder (the exporter's `nnfmu.export.graph.GraphBuilder` provides it)."""

    def constant(self, name: str, value: np.ndarray) -> str:
        """Add an initializer (float64 or int64 array); return its (unique) tensor name."""
        ...

    def node(self, op_type: str, inputs: list[str], name: str, **attributes: Any) -> str:
        """Add one single-output node; return the name of its output tensor."""
        ...


@dataclass(frozen=True)
class StateSlot:
    """One element of the step graph's state vector: what it holds, the channel whose unit it has, its value at rest,
    and the power of its channel's first value it holds at a relaxed start (1: the value, 2: its square; 0: none, it
    keeps `initial`)."""

    name: str
    channel: str
    initial: float = 0.0
    description: str = ""
    power: int = 1


STARTED = "started"  # the relaxed-start flag's state slot: 0 before the first sample, 1 after


def _check_channel_name(channel: object, what: str) -> str:
    if not isinstance(channel, str) or not channel.strip():
        raise SettingsError(f"{what}: channel name must be a non-empty string, got {channel!r}")
    return channel


def _check_positive(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise SettingsError(f"{what} must be a finite number > 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Tap:
    """One input channel at several sample delays; delay 0 is the current sample, d is the sample k-d."""

    channel: str
    delays: tuple[int, ...] = (0,)

    def __post_init__(self) -> None:
        _check_channel_name(self.channel, "tap")
        delays = tuple(self.delays)
        if not delays:
            raise SettingsError(f"tap {self.channel!r}: no delays given")
        for d in delays:
            if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 0:
                raise SettingsError(f"tap {self.channel!r}: delay {d!r} is not an integer >= 0")
        if len(set(delays)) != len(delays):
            raise SettingsError(f"tap {self.channel!r}: duplicate delay in {delays}")
        object.__setattr__(self, "delays", tuple(int(d) for d in delays))

    @property
    def depth(self) -> int:
        """Number of past samples the tap's delay line keeps (its state slots)."""
        return max(self.delays)

    def feature_name(self, delay: int) -> str:
        return f"{self.channel}[k]" if delay == 0 else f"{self.channel}[k-{delay}]"


@dataclass(frozen=True)
class Derived(ABC):
    """A feature computed from one input channel at the current sample (possibly with internal state)."""

    kind: ClassVar[str]
    channel: str

    def __post_init__(self) -> None:
        _check_channel_name(self.channel, self.kind)

    @property
    def name(self) -> str:
        params = ", ".join(f"{f.name}={float(getattr(self, f.name))!r}" for f in fields(self) if f.name != "channel")
        return f"{self.kind}({self.channel}, {params})" if params else f"{self.kind}({self.channel})"

    def state_slots(self) -> tuple[StateSlot, ...]:
        """State the feature carries from one sample to the next (none by default)."""
        return ()

    @abstractmethod
    def compute(self, x: np.ndarray, initial: np.ndarray, sample_period: float) -> np.ndarray:
        """x: (n,) channel from sample 0; initial: (len(state_slots),) -> feature (n,)."""

    @abstractmethod
    def emit(self, g: NodeSink, x: str, state: str | None, sample_period: float) -> tuple[str, str | None]:
        """Nodes for one sample: x [1], state [len(state_slots)] or None -> (feature [1], state_next or None)."""

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **{f.name: getattr(self, f.name) for f in fields(self)}}


@dataclass(frozen=True)
class SmoothSign(Derived):
    """tanh(x / scale): the Coulomb friction sign of a velocity, smoothed over |x| ~ scale."""

    kind: ClassVar[str] = "smooth_sign"
    scale: float = 0.01

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "scale", _check_positive(self.scale, f"smooth_sign({self.channel}) scale"))

    def compute(self, x: np.ndarray, initial: np.ndarray, sample_period: float) -> np.ndarray:
        return np.tanh(x / self.scale)

    def emit(self, g: NodeSink, x: str, state: str | None, sample_period: float) -> tuple[str, str | None]:
        scale = g.constant("smooth_sign_scale", np.array([self.scale]))
        return g.node("Tanh", [g.node("Div", [x, scale], "smooth_sign_div")], "smooth_sign"), None


@dataclass(frozen=True)
class Lowpass(Derived):
    """First-order low-pass of a channel, time constant tau [s]: y_k = y_{k-1} + a (x_k - y_{k-1}).

    a = 1 - exp(-T/tau) is the exact discretisation of tau dy/dt = x - y with x held at x_k over the sample
    interval ending at sample k; the state slot holds y_{k-1}, 0 at rest.
    """

    kind: ClassVar[str] = "lowpass"
    tau: float = 0.01

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "tau", _check_positive(self.tau, f"lowpass({self.channel}) tau"))

    def coefficient(self, sample_period: float) -> float:
        return -math.expm1(-sample_period / self.tau)

    def state_slots(self) -> tuple[StateSlot, ...]:
        return (
            StateSlot(name=f"{self.name}[k-1]", channel=self.channel, description=f"previous output of {self.name}"),
        )

    def compute(self, x: np.ndarray, initial: np.ndarray, sample_period: float) -> np.ndarray:
        a = self.coefficient(sample_period)
        y, _ = lfilter([a], [1.0, -(1.0 - a)], x, zi=[(1.0 - a) * float(initial[0])])
        return y

    def emit(self, g: NodeSink, x: str, state: str | None, sample_period: float) -> tuple[str, str | None]:
        assert state is not None, "lowpass has a state slot"
        a = g.constant("lowpass_coefficient", np.array([self.coefficient(sample_period)]))
        step = g.node("Mul", [g.node("Sub", [x, state], "lowpass_error"), a], "lowpass_step")
        y = g.node("Add", [state, step], "lowpass")
        return y, y


@dataclass(frozen=True)
class LowpassSquare(Derived):
    """First-order low-pass of the squared channel, time constant tau [s]: y_k = y_{k-1} + a (x_k² - y_{k-1}).

    A running mean square: of velocity, it follows the power a damper dissipates (F·v ~ c·v²) through the thermal
    lag of oil and tube, so it stands in for the oil temperature when none is measured; of displacement, it is the
    running amplitude² of the motion (amplitude dependence). Same discretisation as `Lowpass`; the state slot holds
    y_{k-1} in the channel's unit squared, 0 at rest.
    """

    kind: ClassVar[str] = "lowpass_square"
    tau: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "tau", _check_positive(self.tau, f"lowpass_square({self.channel}) tau"))

    def coefficient(self, sample_period: float) -> float:
        return -math.expm1(-sample_period / self.tau)

    def state_slots(self) -> tuple[StateSlot, ...]:
        return (
            StateSlot(
                name=f"{self.name}[k-1]",
                channel=self.channel,
                description=f"previous output of {self.name}, in the square of {self.channel}'s unit",
                power=2,
            ),
        )

    def compute(self, x: np.ndarray, initial: np.ndarray, sample_period: float) -> np.ndarray:
        a = self.coefficient(sample_period)
        y, _ = lfilter([a], [1.0, -(1.0 - a)], np.square(x), zi=[(1.0 - a) * float(initial[0])])
        return y

    def emit(self, g: NodeSink, x: str, state: str | None, sample_period: float) -> tuple[str, str | None]:
        assert state is not None, "lowpass_square has a state slot"
        a = g.constant("lowpass_square_coefficient", np.array([self.coefficient(sample_period)]))
        square = g.node("Mul", [x, x], "lowpass_square_input")
        step = g.node("Mul", [g.node("Sub", [square, state], "lowpass_square_error"), a], "lowpass_square_step")
        y = g.node("Add", [state, step], "lowpass_square")
        return y, y


@dataclass(frozen=True)
class Highpass(Derived):
    """First-order high-pass of a channel, time constant tau [s]: x_k - y_k with y the `Lowpass` of x (same tau).

    What a Maxwell branch of stiffness c carries is c·highpass(position, tau), so a bank of these is the memory of
    a generalised Maxwell material with inputs that are not collinear with the position itself (a low-pass bank is:
    the net then forms x - lowpass(x) itself from large opposite weights). The state slot holds the low-pass part
    y_{k-1}, 0 at rest; same exact discretisation as `Lowpass`.
    """

    kind: ClassVar[str] = "highpass"
    tau: float = 0.01

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "tau", _check_positive(self.tau, f"highpass({self.channel}) tau"))

    def coefficient(self, sample_period: float) -> float:
        return -math.expm1(-sample_period / self.tau)

    def state_slots(self) -> tuple[StateSlot, ...]:
        return (
            StateSlot(
                name=f"{self.name}.lowpass[k-1]",
                channel=self.channel,
                description=f"previous low-pass part (input minus output) of {self.name}",
            ),
        )

    def compute(self, x: np.ndarray, initial: np.ndarray, sample_period: float) -> np.ndarray:
        a = self.coefficient(sample_period)
        low, _ = lfilter([a], [1.0, -(1.0 - a)], x, zi=[(1.0 - a) * float(initial[0])])
        return x - low

    def emit(self, g: NodeSink, x: str, state: str | None, sample_period: float) -> tuple[str, str | None]:
        assert state is not None, "highpass has a state slot"
        a = g.constant("highpass_coefficient", np.array([self.coefficient(sample_period)]))
        step = g.node("Mul", [g.node("Sub", [x, state], "highpass_error"), a], "highpass_step")
        low = g.node("Add", [state, step], "highpass_lowpass")
        return g.node("Sub", [x, low], "highpass"), low


@dataclass(frozen=True)
class Difference(Derived):
    """Backward difference of a channel over `delay` samples: x_k - x_{k-delay} (a rate or increment, not a copy).

    Against a tap at k-delay it spans the same inputs but is not nearly collinear with x_k, so the net needs no
    large opposite weights to take the difference. The state slots hold x_{k-1} .. x_{k-delay}, 0 at rest.
    """

    kind: ClassVar[str] = "difference"
    delay: int = 1

    def __post_init__(self) -> None:
        super().__post_init__()
        d = self.delay
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1:
            raise SettingsError(f"difference({self.channel}) delay must be an integer >= 1, got {d!r}")
        object.__setattr__(self, "delay", int(d))

    @property
    def name(self) -> str:
        return f"{self.kind}({self.channel}, delay={self.delay})"

    def state_slots(self) -> tuple[StateSlot, ...]:
        return tuple(
            StateSlot(
                name=f"{self.name}:{self.channel}[k-{j}]",
                channel=self.channel,
                description=f"{self.channel} delayed by {j} samples, for {self.name}",
            )
            for j in range(1, self.delay + 1)
        )

    def compute(self, x: np.ndarray, initial: np.ndarray, sample_period: float) -> np.ndarray:
        history = np.concatenate([np.asarray(initial, dtype=np.float64)[::-1], x])  # history[delay + k] = x_k
        return x - history[: len(x)]

    def emit(self, g: NodeSink, x: str, state: str | None, sample_period: float) -> tuple[str, str | None]:
        assert state is not None, "difference has state slots"
        last = g.constant("difference_oldest", np.array([self.delay - 1], dtype=np.int64))
        value = g.node("Sub", [x, g.node("Gather", [state, last], "difference_delayed", axis=0)], "difference")
        if self.delay == 1:
            return value, x
        starts = g.constant("difference_keep_start", np.array([0], dtype=np.int64))
        ends = g.constant("difference_keep_end", np.array([self.delay - 1], dtype=np.int64))
        kept = g.node("Slice", [state, starts, ends], "difference_kept")
        return value, g.node("Concat", [x, kept], "difference_line", axis=0)


@dataclass(frozen=True)
class Stop(Derived):
    """Stop operator of half-width `radius` (channel unit): s_k = x_k - p_k, with p the play operator's output
    p_k = min(max(p_{k-1}, x_k - r), x_k + r), the driven side of a gap of width 2r that moves only once x closes it.

    Of displacement, s is where the driving side sits in a backlash gap (±r: in contact and pushing; in between:
    crossing the gap after a reversal), or the elastic part of an elastic-perfectly-plastic (Prandtl) element; a bank
    of radii is a Prandtl-Ishlinskii hysteresis model. It stays in [-r, r] wherever the motion is centred. The state
    slot holds p_{k-1}, 0 at rest; the step graph clips with Relu: clip(u, -r, r) = relu(u + r) - relu(u - r) - r.
    """

    kind: ClassVar[str] = "stop"
    radius: float = 0.001

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "radius", _check_positive(self.radius, f"stop({self.channel}) radius"))

    def state_slots(self) -> tuple[StateSlot, ...]:
        return (
            StateSlot(
                name=f"{self.name}.play[k-1]",
                channel=self.channel,
                description=f"previous play-operator output (driven side of the gap) of {self.name}",
            ),
        )

    def compute(self, x: np.ndarray, initial: np.ndarray, sample_period: float) -> np.ndarray:
        r = self.radius
        play = float(initial[0])
        out = np.empty(len(x))
        for k, value in enumerate(np.asarray(x, dtype=np.float64).tolist()):
            play = min(max(play, value - r), value + r)
            out[k] = value - play
        return out

    def emit(self, g: NodeSink, x: str, state: str | None, sample_period: float) -> tuple[str, str | None]:
        assert state is not None, "stop has a state slot"
        r = g.constant("stop_radius", np.array([self.radius]))
        u = g.node("Sub", [x, state], "stop_travel")
        upper = g.node("Relu", [g.node("Add", [u, r], "stop_above_lower")], "stop_relu_lower")
        lower = g.node("Relu", [g.node("Sub", [u, r], "stop_above_upper")], "stop_relu_upper")
        clipped = g.node("Sub", [g.node("Sub", [upper, lower], "stop_inside"), r], "stop")
        return clipped, g.node("Sub", [x, clipped], "stop_play")


DERIVED_KINDS: dict[str, type[Derived]] = {
    cls.kind: cls for cls in (SmoothSign, Lowpass, LowpassSquare, Highpass, Difference, Stop)
}


def derived_from_dict(d: dict[str, Any]) -> Derived:
    """Rebuild a derived feature from its `to_dict` form; unknown kinds or parameters raise ValueError."""
    params = dict(d)
    kind = params.pop("kind", None)
    if kind not in DERIVED_KINDS:
        raise ValueError(f"unknown derived feature kind {kind!r} (known: {sorted(DERIVED_KINDS)})")
    try:
        return DERIVED_KINDS[kind](**params)
    except TypeError as exc:
        raise ValueError(f"derived feature {kind!r}: bad parameters {params!r}: {exc}") from exc


@dataclass(frozen=True)
class FeatureSpec:
    """The model's inputs: delayed input channels (`taps`) then derived features, predicting one `output` channel.

    Feature order: every tap's delays in the order given, then the derived features. State order: every tap's
    delay line (channel[k-1] .. channel[k-depth]) in tap order, then the derived features' slots.
    """

    taps: tuple[Tap, ...]
    output: str
    derived: tuple[Derived, ...] = ()
    relaxed_start: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.relaxed_start, bool):
            raise SettingsError(f"relaxed_start must be true or false, got {self.relaxed_start!r}")
        object.__setattr__(self, "taps", tuple(self.taps))
        object.__setattr__(self, "derived", tuple(self.derived))
        _check_channel_name(self.output, "output")
        if not self.taps and not self.derived:
            raise SettingsError("feature spec has no features: give at least one tap or derived feature")
        seen: set[str] = set()
        for tap in self.taps:
            if not isinstance(tap, Tap):
                raise SettingsError(f"tap must be a Tap, got {tap!r}")
            if tap.channel in seen:
                raise SettingsError(f"channel {tap.channel!r} is tapped twice; list all its delays in one Tap")
            seen.add(tap.channel)
        for d in self.derived:
            if not isinstance(d, Derived):
                raise SettingsError(f"derived feature must be a Derived, got {d!r}")
        names = self.feature_names
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise SettingsError(f"duplicate feature names {duplicates}")
        if self.output in self.channels:
            raise SettingsError(f"output channel {self.output!r} is also an input channel")

    @property
    def channels(self) -> list[str]:
        """Input channels the step graph needs, in first-use order (taps, then derived)."""
        ordered = [t.channel for t in self.taps] + [d.channel for d in self.derived]
        return list(dict.fromkeys(ordered))

    @property
    def feature_names(self) -> list[str]:
        return [t.feature_name(d) for t in self.taps for d in t.delays] + [d.name for d in self.derived]

    @property
    def n_features(self) -> int:
        return len(self.feature_names)

    def feature_slots(self) -> list[StateSlot]:
        """What the delay lines and derived features keep from one sample to the next, in order, with their value at
        rest."""
        slots = [
            StateSlot(name=t.feature_name(j), channel=t.channel, description=f"{t.channel} delayed by {j} samples")
            for t in self.taps
            for j in range(1, t.depth + 1)
        ]
        for d in self.derived:
            slots.extend(d.state_slots())
        return slots

    def state_layout(self) -> list[StateSlot]:
        """What the feature part of the state vector holds, in order, with its value at rest: the feature slots, then
        (relaxed start, if there are any) the `STARTED` flag."""
        slots = self.feature_slots()
        if self.relaxed_start and slots:
            slots.append(
                StateSlot(
                    name=STARTED,
                    channel="",
                    description="0 before the first sample, then 1: the first sample sets every other slot to its "
                    "channel's value (relaxed start)",
                    power=0,
                )
            )
        return slots

    def initial_state(self, first: dict[str, float] | None) -> np.ndarray:
        """The feature state before sample 0: at rest, or with `relaxed_start` each slot at its power of its
        channel's first value (`first`: channel -> value at sample 0; None: no sample) and the flag set, as the step
        graph makes it."""
        slots = self.state_layout()
        if not self.relaxed_start or first is None:
            return np.array([s.initial for s in slots], dtype=np.float64)
        return np.array(
            [1.0 if s.name == STARTED else float(first[s.channel]) ** s.power if s.power else s.initial for s in slots],
            dtype=np.float64,
        )

    @property
    def state_size(self) -> int:
        return len(self.state_layout())

    def _check_channels(self, channels: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], int]:
        arrays: dict[str, np.ndarray] = {}
        for name in self.channels:
            if name not in channels:
                raise ValueError(f"input channel {name!r} missing (have {sorted(channels)})")
            x = np.asarray(channels[name], dtype=np.float64)
            if x.ndim != 1:
                raise ValueError(f"channel {name!r} must be 1-D, got shape {x.shape}")
            arrays[name] = x
        lengths = {name: len(x) for name, x in arrays.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"channels have different lengths: {lengths}")
        return arrays, next(iter(lengths.values()))

    def features(self, channels: dict[str, np.ndarray], sample_period: float) -> np.ndarray:
        """Feature matrix (n, n_features) of the step graph run sample by sample over `channels` from rest (or
        relaxed at their first values, `relaxed_start`)."""
        sample_period = _check_positive(sample_period, "sample period")
        arrays, n = self._check_channels(channels)
        initial = self.initial_state({c: x[0] for c, x in arrays.items()} if n else None)
        columns: list[np.ndarray] = []
        offset = 0
        for tap in self.taps:
            x = arrays[tap.channel]
            line = initial[offset : offset + tap.depth]  # values at k-1, k-2, ... before sample 0
            history = np.concatenate([line[::-1], x])  # history[tap.depth + k] = x_k
            columns.extend(history[tap.depth - d : tap.depth - d + n] for d in tap.delays)
            offset += tap.depth
        for d in self.derived:
            k = len(d.state_slots())
            columns.append(d.compute(arrays[d.channel], initial[offset : offset + k], sample_period))
            offset += k
        return np.stack(columns, axis=1)

    def emit(
        self, g: NodeSink, inputs: dict[str, str], state: str | None, sample_period: float
    ) -> tuple[str, str | None]:
        """Nodes of one sample: input tensors [1] per channel, state [state_size] or None
        -> (features [n_features], state_next [state_size] or None)."""
        sample_period = _check_positive(sample_period, "sample period")
        slots = self.feature_slots()
        relaxing = self.relaxed_start and bool(slots)
        if relaxing:
            assert state is not None, "spec has state slots"
            state = self._relaxed(g, inputs, state, slots)
        # Pool every available value in one vector, then pick features and next state from it with Gather.
        parts = [inputs[c] for c in self.channels]
        position = {c: i for i, c in enumerate(self.channels)}
        size = len(parts)
        state_base = size
        if slots:
            assert state is not None, "spec has state slots"
            parts.append(state)
            size += len(slots)
        feature_index: list[int] = []
        next_index: list[int] = []
        offset = 0
        for tap in self.taps:
            for delay in tap.delays:
                feature_index.append(position[tap.channel] if delay == 0 else state_base + offset + delay - 1)
            if tap.depth:
                next_index.extend([position[tap.channel]] + [state_base + offset + j for j in range(tap.depth - 1)])
            offset += tap.depth
        for d in self.derived:
            k = len(d.state_slots())
            slot = None
            if k:
                starts = g.constant("state_slot_start", np.array([offset], dtype=np.int64))
                ends = g.constant("state_slot_end", np.array([offset + k], dtype=np.int64))
                slot = g.node("Slice", [state, starts, ends], "state_slot")
            value, value_next = d.emit(g, inputs[d.channel], slot, sample_period)
            parts.append(value)
            feature_index.append(size)
            size += 1
            if k:
                parts.append(value_next)
                next_index.extend(range(size, size + k))
                size += k
            offset += k
        pool = g.node("Concat", parts, "feature_pool", axis=0) if len(parts) > 1 else parts[0]
        indices = g.constant("feature_index", np.array(feature_index, dtype=np.int64))
        features = g.node("Gather", [pool, indices], "features", axis=0)
        if not next_index:
            return features, None
        next_indices = g.constant("state_next_index", np.array(next_index, dtype=np.int64))
        state_next = g.node("Gather", [pool, next_indices], "feature_state_next", axis=0)
        if relaxing:
            state_next = g.node(
                "Concat", [state_next, g.constant("started_after", np.ones(1))], "feature_state_next_started", axis=0
            )
        return features, state_next

    @staticmethod
    def _relaxed(g: NodeSink, inputs: dict[str, str], state: str, slots: list[StateSlot]) -> str:
        """The feature slots a sample works from with a relaxed start: state * started + relaxed * (1 - started),
        `relaxed` each slot's power of its channel's current input; exactly the held slots once started is 1."""
        n = len(slots)
        bounds = [g.constant(f"relaxed_bound{i}", np.array([i], dtype=np.int64)) for i in (0, n, n + 1)]
        held = g.node("Slice", [state, bounds[0], bounds[1]], "relaxed_held")
        started = g.node("Slice", [state, bounds[1], bounds[2]], "relaxed_started")
        values = []
        for slot in slots:
            x = inputs[slot.channel]
            if slot.power == 1:
                values.append(x)
            elif slot.power == 2:
                values.append(g.node("Mul", [x, x], "relaxed_square"))
            else:
                raise ValueError(f"state slot {slot.name!r}: no relaxed value of power {slot.power}")
        relaxed = g.node("Concat", values, "relaxed_values", axis=0) if len(values) > 1 else values[0]
        waiting = g.node("Sub", [g.constant("relaxed_one", np.ones(1)), started], "relaxed_waiting")
        return g.node(
            "Add",
            [g.node("Mul", [held, started], "relaxed_kept"), g.node("Mul", [relaxed, waiting], "relaxed_set")],
            "relaxed_state",
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "taps": [{"channel": t.channel, "delays": list(t.delays)} for t in self.taps],
            "output": self.output,
            "derived": [d.to_dict() for d in self.derived],
        } | ({"relaxed_start": True} if self.relaxed_start else {})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "FeatureSpec":
        try:
            taps = tuple(Tap(t["channel"], tuple(t.get("delays", (0,)))) for t in d["taps"])
            output = d["output"]
        except (KeyError, TypeError) as exc:
            raise ValueError(f"feature spec dict is malformed: {exc!r} in {d!r}") from exc
        relaxed = d.get("relaxed_start", False)
        if not isinstance(relaxed, bool):
            raise ValueError(f"feature spec: relaxed_start is {relaxed!r}, expected true or false")
        derived = tuple(derived_from_dict(x) for x in d.get("derived", []))
        return cls(taps=taps, output=output, derived=derived, relaxed_start=relaxed)
