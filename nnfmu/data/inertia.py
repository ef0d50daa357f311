"""Fixture inertia compensation: the load cell of a dyno also carries the mass moving between it and the actuator.

A damper dyno's load cell measures the damper force plus m·a of the rod, piston and fixture moving with the actuator
(1-3 kg). In a vehicle that mass belongs to the unsprung mass, which the vehicle model already carries, so a network
trained on the raw force would add it a second time: along a road-test motion 2 kg of fixture is about 2.5 % NRMSE of
the damper force (bench/road_test.py). Dyno software subtracts it ("mass compensation"); so does this, with the mass
the lab knows from its dyno: force - mass·a, where a is the measured acceleration, else the derivative of the
measured velocity, else the second derivative of the displacement (Savitzky-Golay, `derive`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from nnfmu.data.derive import derivative
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement


def stroke_acceleration(m: Measurement) -> tuple[np.ndarray, str]:
    """The stroke acceleration [m/s^2] of `m` and where it came from: the measured acceleration, else the derivative
    of the measured velocity, else the second derivative of the displacement; DataError when there is none."""
    if "acceleration" in m.channels and m.units["acceleration"] == "m/s^2":
        return m["acceleration"], "the acceleration channel"
    if "velocity" in m.channels and m.units["velocity"] == "m/s":
        return derivative(m["velocity"], m.sample_period, 1), "d/dt of the measured velocity"
    if "displacement" in m.channels and m.units["displacement"] == "m":
        return derivative(m["displacement"], m.sample_period, 2), "d²/dt² of the measured displacement"
    raise DataError(
        f"{m.source}: the moving mass's m·a needs an acceleration [m/s^2], velocity [m/s] or displacement [m] "
        f"channel (has: {', '.join(m.names)})"
    )


def compensate_inertia(m: Measurement, mass: float, force: str = "force") -> Measurement:
    """`m` with channel `force` [N] less `mass` [kg] times the stroke acceleration [m/s^2], and a note saying so."""
    if not (isinstance(mass, (int, float)) and math.isfinite(mass) and mass >= 0.0):
        raise DataError(f"{m.source}: moving mass {mass!r} must be a finite number of kg >= 0")
    if force not in m.channels:
        raise DataError(
            f"{m.source}: no channel {force!r} to compensate for the moving mass (has: {', '.join(m.names)})"
        )
    if m.units[force] != "N":
        raise DataError(
            f"{m.source}: channel {force!r} is in {m.units[force]}, not N: only a force can be compensated "
            "for a moving mass"
        )
    acceleration, source = stroke_acceleration(m)
    channels = dict(m.channels) | {force: m[force] - mass * acceleration}
    note = f"{force} compensated for {mass:g} kg of moving mass (force - m·a, a from {source})"
    return replace(m, channels=channels, notes=dict(m.notes) | {"inertia": note})
