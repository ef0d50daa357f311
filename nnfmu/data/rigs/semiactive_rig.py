"""A semi-active damper on the dyno: the passive dyno's stroke, a lab-like command to the MR coil or CDC valve, and
the measured record of the `MRDamperTruth` or `CDCDamperTruth` with the command beside stroke and load."""

from __future__ import annotations

import math

import numpy as np

from nnfmu.data.rigs.command import CommandSchedule
from nnfmu.data.rigs.damper_rig import UNITS as PASSIVE_UNITS
from nnfmu.data.rigs.damper_rig import DamperDyno
from nnfmu.data.rigs.sensors import Sensor, record
from nnfmu.physics.cdc_damper import CDC_CURRENT_RANGE, CDCDamperParams, CDCDamperTruth
from nnfmu.physics.mr_damper import MR_VOLTAGE_RANGE, MRDamperParams, MRDamperTruth

# The command channel each semi-active type records, with its unit, range and transducer.
COMMAND_CHANNELS = {"mr": "voltage", "cdc": "current"}
UNITS = {**PASSIVE_UNITS, "voltage": "V", "current": "A"}
COMMAND_SENSORS = {
    "voltage": Sensor(full_scale=10.0, noise_fraction=0.0005),  # ±10 V amplifier monitor, 5 mV rms
    "current": Sensor(full_scale=2.0, noise_fraction=0.0005),  # ±2 A current clamp/shunt, 1 mA rms
}
SCHEDULES = {
    "mr": CommandSchedule(span=MR_VOLTAGE_RANGE, unit="V"),
    "cdc": CommandSchedule(span=CDC_CURRENT_RANGE, unit="A"),
}
PARAMS = {"mr": MRDamperParams, "cdc": CDCDamperParams}


def run_semiactive_dyno(
    damper_type: str,
    params: MRDamperParams | CDCDamperParams,
    effects: tuple[str, ...],
    dyno: DamperDyno,
    rate: float,
    n: int,
    excitation: str,
    noise: float,
    seed: int,
) -> tuple[np.ndarray, dict[str, np.ndarray], dict, dict[str, Sensor]]:
    """Time [s], recorded channels (SI), the truth's description of the run and the transducers of one semi-active
    dyno run (`damper_type` "mr" or "cdc")."""
    substeps = max(1, math.ceil(1 / (rate * dyno.internal_step)))
    fine_rate = rate * substeps
    motion, parts = dyno.motion(excitation, fine_rate, n * substeps, np.random.default_rng([seed, 0]))
    channel = COMMAND_CHANNELS[damper_type]
    command, command_described = SCHEDULES[damper_type].signal(rate, n, np.random.default_rng([seed, 2]))
    fine_command = np.repeat(command, substeps)
    if damper_type == "mr":
        truth: MRDamperTruth | CDCDamperTruth = MRDamperTruth(params, effects)  # type: ignore[arg-type]
        method = "closed-form Bouc-Wen update over each step's deflection, backward Euler for the branch deflection"
    else:
        truth = CDCDamperTruth(params, effects)  # type: ignore[arg-type]
        method = "exact first-order lag of the valve opening (current held over each step)"
    force, _ = truth.simulate(1 / fine_rate, motion.x, motion.v, motion.a, fine_command)
    true = {
        "displacement": motion.x[::substeps],
        "velocity": motion.v[::substeps],
        "force": force[::substeps],
        channel: command,
    }
    sensors = {**{k: v for k, v in dyno.sensors.items() if k in true}, channel: COMMAND_SENSORS[channel]}
    channels = record({k: np.array(v) for k, v in true.items()}, sensors, noise, seed)
    described = {
        "parts": parts,
        "command": {"channel": channel, **command_described},
        "integration": {"internal_rate_Hz": fine_rate, "method": method},
        "sign_convention": "displacement: extension from mid-stroke (rebound +); force: tension (rebound +)",
        "recorded_velocity": "true stroke velocity plus velocity-transducer noise",
        "recorded_command": f"the commanded {channel} (before the {'coil' if damper_type == 'mr' else 'valve'}'s lag)"
        " plus transducer noise",
    }
    return np.arange(n) / rate, channels, described, sensors
