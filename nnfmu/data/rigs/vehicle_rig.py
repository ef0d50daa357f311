"""A bushing rig run on a drive derived from a vehicle result: design, transducers sized for the test, record, truth.

A four-poster moves a front LCA bushing by micrometres radially and milliradians conically, a few per cent of the
range the default bushing rig drives and its transducers cover; recorded with those transducers such a drive would be
mostly noise (the thesis's conical channel used <1 % of its load cell). A lab picks each transducer's range for the
test, so by default every channel's full scale is the smallest of a 1-2-5 series covering `headroom` times the
test's peak (never above the rig's default transducer); the noise stays the same share of full scale.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from nnfmu.data.load import load_measurement
from nnfmu.data.measurement import Measurement
from nnfmu.data.rigs.bushing_rig import RUN_NOTES, UNITS, BushingRig, describe_params, true_signals
from nnfmu.data.rigs.options import VEHICLE_EXCITATION, RigOptions, check_options, resolve_duration, resolve_effects
from nnfmu.data.rigs.sensors import Sensor, record
from nnfmu.data.rigs.simulate import RigRun, write_run
from nnfmu.data.rigs.truth import build_truth
from nnfmu.data.rigs.vehicle_drive import DriveDesign, design_vehicle_drive
from nnfmu.physics.bushing import BushingParams


def transducers_for(
    true: dict[str, np.ndarray], design: DriveDesign, rig: BushingRig = BushingRig()
) -> dict[str, Sensor]:
    """The transducer of every recorded channel: the rig's default, or (`design.fit_sensors`) sized for its peak."""
    if not design.fit_sensors:
        return {name: rig.sensors[name] for name in true}
    return {
        name: rig.sensors[name].sized_for(float(np.max(np.abs(values))), design.headroom)
        for name, values in true.items()
    }


def simulate_vehicle_rig(
    source: Measurement,
    elements: Sequence[str],
    options: RigOptions = RigOptions(),
    design: DriveDesign = DriveDesign(),
    params: BushingParams | None = None,
) -> RigRun:
    """The bushing rig driven by a drive derived from the deflections of `elements` in the vehicle result `source`
    (`design_vehicle_drive`); `options` give length (default 60 s), rate, seed, noise and effects (its excitation is
    set to 'vehicle'). Raises DataError naming the file and channel for a missing, misunited or still deflection."""
    options = replace(options, excitation=VEHICLE_EXCITATION)
    check_options("bushing", options)
    effects = resolve_effects("bushing", options.effects)
    duration = resolve_duration("bushing", options)
    rate = options.sample_rate
    n = int(round(duration * rate))
    params = params or BushingParams()
    drive = design_vehicle_drive(source, elements, rate, n, options.seed, design)
    true = true_signals(params, effects, drive.motions, rate)
    sensors = transducers_for(true, design)
    channels = record(true, sensors, options.noise, options.seed)
    measurement = Measurement(
        time=np.arange(n) / rate,
        channels=channels,
        units={k: UNITS[k] for k in channels},
        source=f"nnfmu rig bushing driven from {', '.join(drive.elements)} in {source.source} (seed {options.seed})",
    )
    defaults = BushingRig().sensors
    recorded = {
        name: sensors[name].describe()
        | {
            "rig_default_full_scale": defaults[name].full_scale,
            "test_peak": float(np.max(np.abs(true[name]))),
            "chosen": f"sized for the test (1-2-5 series, headroom {design.headroom:g})"
            if design.fit_sensors
            else "the rig's default transducer",
        }
        for name in channels
    }
    excitation = {"drives": drive.describe(), **RUN_NOTES}
    truth = build_truth(
        "bushing", effects, describe_params(params), excitation, recorded, options, duration, measurement.units
    )
    return RigRun(measurement, json.loads(json.dumps(truth, allow_nan=False)))


def write_vehicle_rig(
    source: str | os.PathLike[str],
    elements: Sequence[str],
    out: str | os.PathLike[str],
    options: RigOptions = RigOptions(),
    design: DriveDesign = DriveDesign(),
) -> tuple[Path, Path]:
    """Load the vehicle result file `source`, simulate the rig on a drive derived from `elements`, and write the data
    (CSV or MDF4 by the suffix of `out`) and `<out without suffix>.truth.json`; returns both paths."""
    return write_run(simulate_vehicle_rig(load_measurement(source), elements, options, design), Path(out))
