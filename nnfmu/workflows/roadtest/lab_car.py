"""A lab car on the four-poster, made from the project's truth physics: what a road-test lab would record.

The lab car is the road-test vehicle closed by the rigs' truth physics (`truth_laws`), with per-element changes the
component networks never saw: extra damper effects switched on (an undeclared `gas_force`), a bushing stiffer than
its rig sample (aged rubber: every stiffness, Maxwell branch and friction level of its truth scaled), and sensor
effects on the recorded channels (a zero offset, white noise). It is solved monolithically (`monolithic_reference`)
from rest on its own physics and recorded like a lab export: the actuator drives beside the chosen channels, every
channel named `name [unit]` in the CSV. What was changed is written beside the record (`<record>.truth.json`); the
vehicle loop never reads it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from nnfmu.atomic import write_text_atomic
from nnfmu.data import Measurement, save_measurement
from nnfmu.physics import DAMPER_EFFECTS, BushingChannelParams, BushingChannelTruth, DamperTruth
from nnfmu.vehicle import BushingTruthLaw, ComponentLaw, DamperTruthLaw, VehicleBuildSettings, truth_laws, vehicle_model
from nnfmu.workflows.roadtest.systems import RoadTestError, bushing_elements, damper_elements, vehicle_components
from nnfmu.workflows.roadtest.truth_reference import monolithic_reference

# What a lab records on the four-poster: the actuator drives, LCA angles, damper load cells and LVDTs, spindle and
# body accelerometers (vehicle output names; a lab export is renamed to them with `--map`).
LAB_CHANNELS: dict[str, tuple[str, ...]] = {
    "quarter-car": ("damper_force", "damper_displacement", "body_acceleration", "spindle_acceleration"),
    "full-vehicle": (
        "lca_fl_angle",
        "lca_fr_angle",
        *(f"damper_{c}_force" for c in ("fl", "fr", "rl", "rr")),
        *(f"damper_{c}_displacement" for c in ("fl", "fr", "rl", "rr")),
        *(f"spindle_{c}_acceleration" for c in ("fl", "fr", "rl", "rr")),
        *(f"body_acceleration_{c}" for c in ("fl", "fr", "rl", "rr")),
    ),
}
BUSHING_FORCES = ("axial_force", "radial_force", "axial_torque", "conical_torque")


@dataclass(frozen=True)
class LabCar:
    """How the lab car differs from the networks' training: `damper_effects` (damper element -> truth effects
    switched on beside the defaults, e.g. {"damper_fr": ("gas_force",)}), `bushing_stiffness` (bushing element ->
    factor on its truth stiffnesses, e.g. {"bushing_fl_front": 1.5}), `offsets` (channel -> zero offset, channel
    unit), `noise` (white sensor noise, as a fraction of each recorded channel's rms about its mean; the drives are
    recorded clean), `channels` recorded beside the drives (empty: `LAB_CHANNELS`), `seed` of the noise."""

    system: str = "full-vehicle"
    damper_effects: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    bushing_stiffness: Mapping[str, float] = field(default_factory=dict)
    offsets: Mapping[str, float] = field(default_factory=dict)
    noise: float = 0.002
    channels: tuple[str, ...] = ()
    seed: int = 0

    def __post_init__(self) -> None:
        if self.system not in LAB_CHANNELS:
            raise RoadTestError(f"lab car: unknown system {self.system!r}; choose one of {', '.join(LAB_CHANNELS)}")
        dampers, bushings = damper_elements(self.system), bushing_elements(self.system)
        for element, effects in self.damper_effects.items():
            if element not in dampers:
                raise RoadTestError(f"lab car: no damper {element!r} in the {self.system} (has: {', '.join(dampers)})")
            unknown = [e for e in effects if e not in DAMPER_EFFECTS or e == "inertia"]
            if unknown:
                raise RoadTestError(
                    f"lab car: damper {element!r}: effect(s) {unknown} cannot be switched on in a vehicle "
                    f"(choose from {', '.join(e for e in DAMPER_EFFECTS if e != 'inertia')})"
                )
        for element, factor in self.bushing_stiffness.items():
            if element not in bushings:
                raise RoadTestError(
                    f"lab car: no network bushing {element!r} in the {self.system} "
                    f"(has: {', '.join(bushings) or 'none'})"
                )
            if not (math.isfinite(factor) and factor > 0):
                raise RoadTestError(f"lab car: bushing {element!r}: stiffness factor {factor!r} must be positive")
        if not (math.isfinite(self.noise) and self.noise >= 0):
            raise RoadTestError(f"lab car: noise {self.noise!r} must be a fraction >= 0 of a channel's rms")
        for channel, value in self.offsets.items():
            if channel not in self.recorded or not math.isfinite(value):
                raise RoadTestError(
                    f"lab car: offset on {channel!r} = {value!r}: the channel must be recorded and the offset finite "
                    f"(recorded: {', '.join(self.recorded)})"
                )

    @property
    def recorded(self) -> tuple[str, ...]:
        """The channels recorded beside the drives."""
        return self.channels or LAB_CHANNELS[self.system]

    def describe(self) -> dict[str, object]:
        """What was changed, JSON-ready (the hidden truth of the record)."""
        return {
            "system": self.system,
            "damper_effects": {k: list(v) for k, v in self.damper_effects.items()},
            "bushing_stiffness": dict(self.bushing_stiffness),
            "offsets": dict(self.offsets),
            "noise": self.noise,
            "seed": self.seed,
        }


def _scaled(params: BushingChannelParams, factor: float) -> BushingChannelParams:
    """A bushing channel `factor` times as stiff: spring, progressive term, Maxwell branches and friction level."""
    return replace(
        params,
        stiffness=params.stiffness * factor,
        cubic_stiffness=params.cubic_stiffness * factor,
        maxwell_stiffness=tuple(k * factor for k in params.maxwell_stiffness),
        friction_max=params.friction_max * factor,
    )


def lab_car_laws(car: LabCar) -> dict[str, ComponentLaw]:
    """The force law of every port of the lab car: the default truth physics, changed as `car` says."""
    vehicle = vehicle_model(car.system, VehicleBuildSettings(components=vehicle_components(car.system)))
    laws = truth_laws([p.name for p in vehicle.inputs if not p.name.startswith("actuator")])
    for element, extra in car.damper_effects.items():
        law = laws[f"{element}_force"]
        assert isinstance(law, DamperTruthLaw)
        effects = tuple(e for e in DAMPER_EFFECTS if e in law.truth.effects or e in extra)
        laws[f"{element}_force"] = DamperTruthLaw(DamperTruth(law.truth.params, effects))
    for element, factor in car.bushing_stiffness.items():
        for port in BUSHING_FORCES:
            law = laws[f"{element}_{port}"]
            assert isinstance(law, BushingTruthLaw)
            laws[f"{element}_{port}"] = BushingTruthLaw(
                BushingChannelTruth(_scaled(law.truth.params, factor), law.truth.effects)
            )
    return laws


def lab_car_record(car: LabCar, drive: Measurement, step: float = 1e-4) -> Measurement:
    """The lab car driven by `drive` (its `actuator_*_displacement` channels), solved monolithically at `step` [s]
    from rest on its own physics; the drives and `car.recorded` channels, with the sensor offsets and noise."""
    solved = monolithic_reference(car.system, drive, vehicle_components(car.system), step, laws=lab_car_laws(car))
    m = solved.measurement
    absent = [c for c in car.recorded if c not in m]
    if absent:
        raise RoadTestError(f"lab car: the {car.system} has no channel(s) {', '.join(absent)}")
    rng = np.random.default_rng(car.seed)
    channels: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    vehicle = vehicle_model(car.system, VehicleBuildSettings(components=vehicle_components(car.system)))
    for name in (p.name for p in vehicle.inputs if p.name.startswith("actuator_") and p.name.endswith("displacement")):
        channels[name], units[name] = np.asarray(drive[name], dtype=float)[: len(m)].copy(), drive.units[name]
    for name in car.recorded:
        values = np.asarray(m[name], dtype=float)
        spread = float(np.std(values))
        channels[name] = values + car.offsets.get(name, 0.0) + car.noise * spread * rng.standard_normal(len(values))
        units[name] = m.units[name]
    return Measurement(m.time.copy(), channels, units, source=f"lab car ({car.system}) on {drive.source}")


def write_lab_car(car: LabCar, drive: Measurement, path: str | Path, step: float = 1e-4) -> Path:
    """`lab_car_record` written to `path` (CSV `name [unit]` headers, or MDF4 by suffix) with what was changed in
    `<path>.truth.json` beside it; returns the record's path."""
    record = lab_car_record(car, drive, step)
    written = save_measurement(record, path)
    write_text_atomic(Path(f"{written}.truth.json"), json.dumps(car.describe(), indent=1))
    return written
