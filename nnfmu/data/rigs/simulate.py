"""Simulate a rig run (damper dyno or bushing rig) into a `Measurement` and its truth; write both to files."""

from __future__ import annotations

import json
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nnfmu.atomic import atomic_path
from nnfmu.data.errors import DataError
from nnfmu.data.measurement import Measurement
from nnfmu.data.rigs.bushing_rig import UNITS as BUSHING_UNITS
from nnfmu.data.rigs.bushing_rig import BushingRig, describe_params, run_bushing_rig
from nnfmu.data.rigs.damper_rig import UNITS as DAMPER_UNITS
from nnfmu.data.rigs.damper_rig import DamperDyno, run_damper_dyno
from nnfmu.data.rigs.options import VEHICLE_EXCITATION, RigOptions, check_options, resolve_duration, resolve_effects
from nnfmu.data.rigs.semiactive_rig import PARAMS as SEMIACTIVE_PARAMS
from nnfmu.data.rigs.semiactive_rig import UNITS as SEMIACTIVE_UNITS
from nnfmu.data.rigs.semiactive_rig import run_semiactive_dyno
from nnfmu.data.rigs.truth import build_truth, truth_path, truth_text
from nnfmu.data.save import save_measurement
from nnfmu.errors import SettingsError
from nnfmu.physics.bushing import BushingParams
from nnfmu.physics.cdc_damper import CDCDamperParams
from nnfmu.physics.damper import DamperParams
from nnfmu.physics.mr_damper import MRDamperParams
from nnfmu.physics.parameters import describe

RigParams = DamperParams | BushingParams | MRDamperParams | CDCDamperParams


@dataclass
class RigRun:
    """A simulated run: what the rig recorded, and the ground truth that produced it."""

    measurement: Measurement
    truth: dict[str, Any]


def simulate_rig(kind: str, options: RigOptions, params: RigParams | None = None) -> RigRun:
    """Simulate `kind` ("damper" or "bushing", the damper of `options.damper_type`) under `options`; `params`
    (default: realistic defaults of the kind and type) are the truth.

    Raises SettingsError naming an unknown kind, effect, excitation or an unusable option value.
    """
    check_options(kind, options)
    if options.excitation == VEHICLE_EXCITATION:
        raise SettingsError(
            f"a vehicle-derived {kind} drive needs the vehicle's result: use simulate_vehicle_rig "
            f"(nnfmu rig {kind} --drive-from RESULT --element NAME)"
        )
    effects = resolve_effects(kind, options.effects, options.damper_type)
    duration = resolve_duration(kind, options)
    n = int(round(duration * options.sample_rate))
    run_args = (options.sample_rate, n, options.excitation, options.noise, options.seed)
    time, channels, excitation, sensors, units, described = _RUNS[kind](options, params, effects, run_args)
    what = kind if options.damper_type == "passive" else f"{kind} --type {options.damper_type}"
    source = f"nnfmu rig {what} (seed {options.seed})"
    measurement = Measurement(time=time, channels=channels, units={k: units[k] for k in channels}, source=source)
    recorded = {name: sensors[name].describe() for name in channels}
    truth = build_truth(kind, effects, described, excitation, recorded, options, duration, measurement.units)
    return RigRun(measurement, json.loads(json.dumps(truth, allow_nan=False)))  # plain JSON types, as on disk


def _check_params(params: object, expected: type) -> None:
    if not isinstance(params, expected):
        raise TypeError(f"parameters for this rig must be {expected.__name__}, got {type(params).__name__}")


def _damper_run(options: RigOptions, params: RigParams | None, effects: tuple[str, ...], run_args: tuple) -> tuple:
    """The damper dyno's run: the passive damper or the semi-active one of `options.damper_type`."""
    dyno = DamperDyno()
    if options.damper_type != "passive":
        expected = SEMIACTIVE_PARAMS[options.damper_type]
        params = params or expected()
        _check_params(params, expected)
        time, channels, excitation, sensors = run_semiactive_dyno(options.damper_type, params, effects, dyno, *run_args)
        return time, channels, excitation, sensors, SEMIACTIVE_UNITS, describe(params)
    params = params or DamperParams()
    _check_params(params, DamperParams)
    time, channels, excitation = run_damper_dyno(params, effects, dyno, *run_args)
    return time, channels, excitation, dyno.sensors, DAMPER_UNITS, describe(params)


def _bushing_run(options: RigOptions, params: RigParams | None, effects: tuple[str, ...], run_args: tuple) -> tuple:
    """The four-channel bushing rig's run."""
    params = params or BushingParams()
    _check_params(params, BushingParams)
    rig = BushingRig()
    time, channels, excitation = run_bushing_rig(params, effects, rig, *run_args)
    return time, channels, excitation, rig.sensors, BUSHING_UNITS, describe_params(params)


# The simulator of each rig (`options.KINDS`; the rig a component kind names, `nnfmu.kinds`).
_RUNS = {"damper": _damper_run, "bushing": _bushing_run}


def write_rig(kind: str, out: Path, options: RigOptions) -> tuple[Path, Path]:
    """Simulate and write the data (CSV or MDF4 by the suffix of `out`) and `<out without suffix>.truth.json`."""
    return write_run(simulate_rig(kind, options), Path(out))


def write_run(run: RigRun, out: Path) -> tuple[Path, Path]:
    """Write a rig run's data to `out` and its truth beside it; returns both paths.

    Both files or neither: the truth goes to its temporary file before the data is written, and is renamed into
    place after it, so a truth file that cannot be written leaves an earlier record as it was (DataError)."""
    truth = truth_path(out)
    if truth.is_dir():
        raise DataError(f"{truth}: is a folder, so the rig's truth file cannot be written there")
    with ExitStack() as stack:
        try:
            staged = stack.enter_context(atomic_path(truth))
            staged.write_text(truth_text(run.truth), encoding="utf-8")
        except OSError as error:
            raise DataError(f"{truth}: cannot write the rig's truth file: {error.strerror or error}") from None
        try:
            data = save_measurement(run.measurement, out)
        except OSError as error:
            raise DataError(f"{out}: cannot write the rig data: {error.strerror or error}") from None
    return data, truth
