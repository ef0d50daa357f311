"""Sensitivity of the full-vehicle co-simulation to the drive's last bit: 20 s at 1 ms, the drive and the drive with
every sample moved up by one unit in the last place (`numpy.nextafter`), one JSON line.

Usage: python bench/ulp_sensitivity.py MODELS_DIR [DURATION_S] [BUSHINGS]
MODELS_DIR holds <preset>.onnx of the damper and bushing presets (e.g. `nnfmu demo --out D`'s D/models). BUSHINGS:
`network` (the merged bushing networks, as the road test couples them: stabilisers fitted to the networks), `truth`
(the truth physics as FMUs in the same loop) or `linear` (the parameter file's linear bushings built into the
vehicle). Per channel: the largest difference of the two runs relative to the channel's peak; for the worst channel
the time the difference first passes 1e-12 and 0.1 of its peak and the exponential growth rate between the two (a
Lyapunov-like exponent: a stable loop's difference stays near rounding). Plus, for the bushing networks, the sine
tests in which a channel gives energy back (`nnfmu.workflows.passivity`; the networks of MODELS_DIR, whichever
bushings ran), the cause docs/passivity.md names. Results: bench/results/ulp-sensitivity.jsonl.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import onnx

from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import open_system
from nnfmu.data import Measurement
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics.components import REFERENCE
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu
from nnfmu.workflows.passivity import active_cycles
from nnfmu.workflows.roadtest.stabilisers import bushing_stabilisers
from nnfmu.workflows.roadtest.systems import (
    build_component_fmus,
    build_truth_fmus,
    build_vehicle,
    bushing_elements,
    write_system,
)
from nnfmu.workflows.roadtest.truth_reference import settled_state

STEP = 1e-3  # [s]
SYSTEM = "full-vehicle"
DAMPER = "damper-hysteresis"


def system_ssd(models: dict[str, Path], bushings: str, work: Path) -> Path:
    """The full vehicle with damper networks and the chosen bushings, as an SSD in `work`."""
    fmus = build_component_fmus(models, work / "fmu", with_bushing=True)
    if bushings == "linear":
        components = {name: REFERENCE for name in bushing_elements(SYSTEM)}
        settings = VehicleBuildSettings(
            components=components, sample_period=STEP, initial_state=settled_state(SYSTEM, components)
        )
        vehicle = build_vehicle_fmu(SYSTEM, work / "fmu" / "linear-bushings.fmu", settings)
        return write_system(SYSTEM, vehicle, fmus.dampers[DAMPER], None, work / "system")
    stabilisers = bushing_stabilisers(onnx.load(work / "fmu" / "lca-bushing.onnx"), bushing_elements(SYSTEM))
    vehicle = build_vehicle(SYSTEM, work / "fmu", STEP, stabilisers)
    bushing = build_truth_fmus(work / "truth", STEP, True).bushing if bushings == "truth" else fmus.bushing
    return write_system(SYSTEM, vehicle, fmus.dampers[DAMPER], bushing, work / "system")


def growth(time: np.ndarray, difference: np.ndarray, peak: float) -> dict:
    """When the difference passes 1e-12 and 0.1 of `peak`, and its exponential growth rate [1/s] in between."""
    small, large = difference > 1e-12 * peak, difference > 0.1 * peak
    if not small.any() or not large.any():
        return {"passes_1e-12_at_s": None, "passes_0.1_at_s": None, "growth_rate_per_s": None}
    t0, t1 = time[np.argmax(small)], time[np.argmax(large)]
    window = (time >= t0) & (time <= t1) & (difference > 0)
    rate = float(np.polyfit(time[window], np.log(difference[window]), 1)[0]) if window.sum() > 2 else None
    return {"passes_1e-12_at_s": float(t0), "passes_0.1_at_s": float(t1), "growth_rate_per_s": rate}


def main() -> None:
    folder = Path(sys.argv[1])
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
    bushings = sys.argv[3] if len(sys.argv) > 3 else "network"
    models = {path.stem: path for path in folder.glob("*.onnx")}
    drive = generate_drive(DriveSettings(duration=duration + STEP))
    moved = Measurement(
        drive.time, {c: np.nextafter(drive[c], np.inf) for c in drive.names}, dict(drive.units), source="drive+1ulp"
    )
    with tempfile.TemporaryDirectory(prefix="nnfmu-ulp-") as scratch:
        ssd = system_ssd(models, bushings, Path(scratch))
        runs = []
        for signal in (drive, moved):
            with open_system(ssd) as system:
                runs.append(cosimulate(system, signal, CosimSettings(step=STEP, stop_time=duration)).measurement)
        active = active_cycles(onnx.load(Path(scratch) / "fmu" / "lca-bushing.onnx"))
    base, other = runs
    peaks = {c: float(np.max(np.abs(base[c]))) for c in base.names}
    relative = {c: float(np.max(np.abs(base[c] - other[c])) / max(peaks[c], 1e-300)) for c in base.names}
    ranked = sorted(relative, key=relative.get, reverse=True)
    worst = ranked[0]
    record = {
        "duration_s": duration,
        "step_s": STEP,
        "bushings": bushings,
        "models": str(folder),
        "largest_relative_difference": {c: relative[c] for c in ranked[:8]},
        "peaks": {c: peaks[c] for c in ranked[:8]},
        "worst_channel": worst,
        "worst_channel_growth": growth(base.time, np.abs(base[worst] - other[worst]), peaks[worst]),
        "bushing_network_cycles_giving_energy_back": [
            {"channel": c.channel, "amplitude_m": c.amplitude, "frequency_Hz": c.frequency, "energy_J": c.energy}
            for c in active
        ],
    }
    print(json.dumps(record))


if __name__ == "__main__":
    main()
