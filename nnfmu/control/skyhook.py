"""A continuous skyhook controller for a semi-active damper, as an nnfmu step graph (sampled, stateless).

Sign convention (the vehicle's ports, nnfmu/vehicle/dynamics/ports.py and quarter_car.py): `body_velocity` [m/s] is
the sprung mass's absolute vertical velocity, up positive; `damper_velocity` [m/s] the stroke rate, rebound
(extension) positive, r·(v_body − v_wheel) with r the damper motion ratio; the damper force is rebound (tension)
positive, resisting extension, so a force F pulls the body down by r·F. Skyhook asks for the body force −c_sky·v_b
(a damper to an inertial "sky"). A semi-active damper gives F = c·v_r with c >= 0, i.e. −r·c·v_r on the body, which
equals the skyhook force for c = c_sky·v_b / (r·v_r) > 0: only when v_b·v_r > 0 (the stroke's force opposes the body's
motion). `c_sky` is stated along the damper's stroke (the motion ratio folded in, as the damper's own damping is).

Law, per sample: c_des = c_sky·v_b·v_r / (v_r² + ε²) (ε [m/s] keeps it finite near v_r = 0, where it tends to 0),
c = clip(c_des, c_min, c_max) = c_min + Relu(c_des − c_min) − Relu(c_des − c_max), and the command is linear in c,
from the soft command at c_min to the hard one at c_max. Nothing is remembered between samples.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
import onnx

from nnfmu.component import SAMPLE_PERIOD_RANGE
from nnfmu.control.command import SENSOR_PORTS, Command, controller_component, known_command
from nnfmu.errors import SettingsError
from nnfmu.export.graph import GraphBuilder

BODY_VELOCITY, DAMPER_VELOCITY = SENSOR_PORTS


def _number(name: str, value: object, unit: str, low: float, strict: bool) -> None:
    """SettingsError naming `name` unless `value` is a finite number above `low` (or at it when not `strict`)."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < low or (strict and value == low):
        raise SettingsError(
            f"skyhook {name} {value!r} {unit} must be a finite number {'>' if strict else '>='} {low:g}"
        )


@dataclass(frozen=True)
class SkyhookSettings:
    """Skyhook damping `c_sky` [N.s/m] (along the stroke), the damper's realisable range `c_min` to `c_max` [N.s/m],
    the regularising velocity `epsilon` [m/s], the damper `command` and its soft/hard values, and the controller's
    `sample_period` [s]. Checked once, here: SettingsError naming the value.

    Defaults: an MR damper over 0-5 V spanning 1-4 kN.s/m, and c_sky = 3000 N.s/m, about 0.43 of the critical damping
    of the packaged sedan's corner body (2·sqrt(k·m_s) = 6.7 kN.s/m at the wheel, damper motion ratio 0.97)."""

    c_sky: float = 3000.0
    c_min: float = 1000.0
    c_max: float = 4000.0
    epsilon: float = 0.01
    command: Command = field(default_factory=lambda: known_command("voltage"))
    sample_period: float = 1e-3

    def __post_init__(self) -> None:
        _number("c_sky", self.c_sky, "N.s/m", 0.0, strict=False)
        _number("c_min", self.c_min, "N.s/m", 0.0, strict=False)
        _number("c_max", self.c_max, "N.s/m", self.c_min, strict=True)
        _number("epsilon", self.epsilon, "m/s", 0.0, strict=True)
        low, high = SAMPLE_PERIOD_RANGE
        _number("sample_period", self.sample_period, "s", low, strict=False)
        if self.sample_period > high:
            raise SettingsError(f"skyhook sample_period {self.sample_period!r} s must be at most {high:g} s")
        if not isinstance(self.command, Command):
            raise SettingsError(f"skyhook command {self.command!r} must be a Command (see known_command)")

    @property
    def command_per_damping(self) -> float:
        """Command per unit of damping above c_min [command unit per N.s/m]."""
        return (self.command.hard - self.command.soft) / (self.c_max - self.c_min)


def _scalar(g: GraphBuilder, name: str, value: float) -> str:
    """A float64 constant of shape [1] (an int given in the settings must not make an int64 tensor)."""
    return g.constant(name, np.array([float(value)]))


def skyhook_graph(settings: SkyhookSettings | None = None, name: str = "skyhook") -> onnx.ModelProto:
    """Step graph `body_velocity`, `damper_velocity` [m/s] -> the command (settings.command's name and unit),
    sampled every settings.sample_period; the `Component` attached (see the module docstring for the law)."""
    s = settings or SkyhookSettings()
    out = s.command.name
    g = GraphBuilder(reserved=(BODY_VELOCITY, DAMPER_VELOCITY, out))
    product = g.node("Mul", [BODY_VELOCITY, DAMPER_VELOCITY], "body_times_stroke_rate")
    numerator = g.node("Mul", [product, _scalar(g, "c_sky", s.c_sky)], "sky_numerator")
    stroke_squared = g.node("Mul", [DAMPER_VELOCITY, DAMPER_VELOCITY], "stroke_rate_squared")
    denominator = g.node(
        "Add", [stroke_squared, _scalar(g, "epsilon_squared", s.epsilon**2)], "regularised_stroke_rate_squared"
    )
    desired = g.node("Div", [numerator, denominator], "desired_damping")
    above_min = g.node("Relu", [g.node("Sub", [desired, _scalar(g, "c_min", s.c_min)], "over_c_min")], "above_c_min")
    above_max = g.node("Relu", [g.node("Sub", [desired, _scalar(g, "c_max", s.c_max)], "over_c_max")], "above_c_max")
    span = g.node("Sub", [above_min, above_max], "clipped_damping_above_c_min")
    gain = _scalar(g, "command_per_damping", s.command_per_damping)
    scaled = g.node("Mul", [span, gain], "command_change")
    command = g.node("Add", [scaled, _scalar(g, "soft_command", s.command.soft)], "command")
    g.output(command, out)
    law = (
        f"skyhook: c = clip(c_sky v_b v_r / (v_r^2 + eps^2), c_min, c_max), c_sky = {s.c_sky:g} N.s/m, "
        f"eps = {s.epsilon:g} m/s, c in [{s.c_min:g}, {s.c_max:g}] N.s/m -> {out} {s.command.soft:g} to "
        f"{s.command.hard:g} {s.command.unit}"
    )
    model = g.model(name, law, [(BODY_VELOCITY, 1), (DAMPER_VELOCITY, 1)], [(out, 1)])
    controller_component(
        name,
        s.command,
        "semi-active damper command from the skyhook law",
        s.sample_period,
        law,
        {"controller": "skyhook", "settings": asdict(s)},
    ).attach_to(model)
    onnx.checker.check_model(model)
    return model
