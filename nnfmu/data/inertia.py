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

from nnfmu.data.derive import derivative
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement


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
    if "acceleration" in m.channels and m.units["acceleration"] == "m/s^2":
        acceleration, source = m["acceleration"], "the measured acceleration"
    elif "velocity" in m.channels and m.units["velocity"] == "m/s":
        acceleration, source = derivative(m["velocity"], m.sample_period, 1), "d/dt of the measured velocity"
    elif "displacement" in m.channels and m.units["displacement"] == "m":
        acceleration, source = derivative(m["displacement"], m.sample_period, 2), "d²/dt² of the measured displacement"
    else:
        raise DataError(
            f"{m.source}: compensating {force!r} for a moving mass needs an acceleration [m/s^2], "
            f"velocity [m/s] or displacement [m] channel (has: {', '.join(m.names)})"
        )
    channels = dict(m.channels) | {force: m[force] - mass * acceleration}
    note = f"{force} compensated for {mass:g} kg of moving mass (force - m·a, a from {source})"
    return replace(m, channels=channels, notes=dict(m.notes) | {"inertia": note})
