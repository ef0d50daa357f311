"""A damper dyno run whose random part follows the car's damper strokes (the thesis's rig data design for dampers).

The record keeps the lab schedule's sine series (the characteristic at standard peak velocities) up to the first level
at or above the car's fastest stroke rate times the margin (`sine_peak_velocities`), and replaces its band-limited
random part, flat in velocity over 1-20 Hz, by a stroke derived from the dampers of a
vehicle result (`design_damper_drive`: spectrum following the simulated strokes up to the dyno's 100 Hz, excursions
and peak rate over the simulated ones by a margin, about the simulated working point). The dyno's own transducers
record it: the car's strokes fill most of their ranges.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from nnfmu.data.load import load_measurement
from nnfmu.data.measurement import Measurement
from nnfmu.data.rigs.damper_rig import UNITS, DamperDyno, run_damper_dyno
from nnfmu.data.rigs.excitation import Motion
from nnfmu.data.rigs.options import VEHICLE_EXCITATION, RigOptions, check_options, resolve_duration, resolve_effects
from nnfmu.data.rigs.simulate import RigRun, write_run
from nnfmu.data.rigs.truth import build_truth
from nnfmu.data.rigs.vehicle_drive import DriveDesign, VehicleDrive, damper_stroke, design_damper_drive
from nnfmu.physics.damper import DamperParams
from nnfmu.physics.parameters import describe


def sine_peak_velocities(
    source: Measurement, elements: Sequence[str], margin: float, levels: Sequence[float]
) -> tuple[float, ...]:
    """The dyno's sine `levels` [m/s] up to the first at or above `margin` times the fastest stroke rate of the damper
    `elements` in `source` (all of them when none is): levels the car never reaches take the network's capacity from
    where it works (the road test's hysteresis network: 1.85 % NRMSE along the car with levels to 3 m/s for a car
    reaching 1.1 m/s, 1.29 % with levels to 1.5 m/s; docs/rig-data.md)."""
    rates = [np.max(np.abs(np.gradient(damper_stroke(source, e), source.sample_period))) for e in elements]
    peak = margin * float(max(rates, default=math.inf))
    reaching = [i for i, level in enumerate(levels) if level >= peak]
    return tuple(levels[: reaching[0] + 1]) if reaching else tuple(levels)


def simulate_vehicle_damper_dyno(
    source: Measurement,
    elements: Sequence[str],
    options: RigOptions = RigOptions(),
    design: DriveDesign = DriveDesign(),
    params: DamperParams | None = None,
) -> RigRun:
    """The damper dyno on the lab sine series (`sine_peak_velocities`: the levels the car needs), then a stroke
    derived from the damper `elements` of the vehicle result `source`; `options` give length (default 70 s), rate,
    seed, noise and effects (its excitation is set to 'vehicle'). Raises DataError naming the file and channel for a
    missing, misunited or still stroke."""
    options = replace(options, excitation=VEHICLE_EXCITATION)
    check_options("damper", options)
    effects = resolve_effects("damper", options.effects)
    duration = resolve_duration("damper", options)
    n = int(round(duration * options.sample_rate))
    params = params or DamperParams()
    lab = DamperDyno()
    dyno = replace(lab, peak_velocities=sine_peak_velocities(source, elements, design.margin, lab.peak_velocities))
    designed: list[VehicleDrive] = []

    def derived(rate: float, samples: int) -> tuple[Motion, dict]:
        drive = design_damper_drive(source, elements, rate, samples, options.seed, design)
        designed.append(drive)
        motion = drive.motions["displacement"]
        return motion, {
            "type": "vehicle-derived stroke",
            "peak_velocity_m/s": float(np.max(np.abs(motion.v))),
            "peak_displacement_m": float(np.max(np.abs(motion.x))),
            "rms_velocity_m/s": float(np.sqrt(np.mean(motion.v**2))),
        }

    time, channels, excitation = run_damper_dyno(
        params, effects, dyno, options.sample_rate, n, VEHICLE_EXCITATION, options.noise, options.seed, derived
    )
    excitation["drive"] = designed[0].describe()
    measurement = Measurement(
        time=time,
        channels=channels,
        units={k: UNITS[k] for k in channels},
        source=f"nnfmu rig damper driven from {', '.join(elements)} in {source.source} (seed {options.seed})",
    )
    recorded = {name: dyno.sensors[name].describe() for name in channels}
    truth = build_truth("damper", effects, describe(params), excitation, recorded, options, duration, measurement.units)
    return RigRun(measurement, json.loads(json.dumps(truth, allow_nan=False)))


def write_vehicle_damper_dyno(
    source: str | os.PathLike[str],
    elements: Sequence[str],
    out: str | os.PathLike[str],
    options: RigOptions = RigOptions(),
    design: DriveDesign = DriveDesign(),
) -> tuple[Path, Path]:
    """Load the vehicle result file `source`, simulate the dyno on a stroke derived from `elements`, and write the
    data (CSV or MDF4 by the suffix of `out`) and `<out without suffix>.truth.json`; returns both paths."""
    return write_run(simulate_vehicle_damper_dyno(load_measurement(source), elements, options, design), Path(out))
