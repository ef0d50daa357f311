"""An nnfmu damper network in masters nnfmu did not write, on a vehicle nnfmu did not write: the table of
docs/masters.md ("Using nnfmu FMUs in your master").

The vendor-style quarter car (tests/vendor/quarter_car.c: RK4 substeps, the damper force held over the step, no input
interpolation, Modelica unit spellings) with (a) the damper-hysteresis preset trained on a default lab dyno record
(70 s, seed 0, the fixture's 2 kg taken out) and (b) the dyno's truth law as an nnfmu FMU (coupling only), coupled by
a plain fmpy Gauss-Seidel loop, a plain fmpy Jacobi loop and libcosim (Jacobi) at h = 1, 0.5 and 0.1 ms, 20 s of
smooth random road with a pothole, against the monolithic RK4 solution of the same car with the truth law inside.
The network's own error is its replay at h = T on the reference's damper motion (open loop).

Usage: python bench/plain_masters.py OUT_DIR [DURATION_S]  -> JSON on the last line
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "vendor"))  # the vendor car, test-made
from plain_coupling import libcosim_loop, monolithic, nrmse, plain_loop, replay  # noqa: E402
from vendor_fmu import build_vendor_quarter_car  # noqa: E402

from nnfmu.data.rigs import DamperTruth, RigOptions, write_rig  # noqa: E402
from nnfmu.fmu.build import build_fmu, build_fmu_from_model  # noqa: E402
from nnfmu.fmu.options import BuildOptions  # noqa: E402
from nnfmu.workflows.roadtest.truth_graphs import damper_truth_graph  # noqa: E402
from nnfmu.workflows.train import TrainRequest, train_from_file  # noqa: E402

T = 1e-3
REFERENCE_STEP = 1e-4
STEPS = (1e-3, 5e-4, 1e-4)
CHANNELS = ("damper_force", "body_acceleration")
TRUTH = DamperTruth(effects=("hysteresis", "seal_friction"))


def coupled(car: Path, damper: Path, duration: float, h: float, master: str) -> np.ndarray:
    """Damper force and body acceleration rows at t = k h (k from 1) from one master."""
    if master == "libcosim":
        return libcosim_loop(car, damper, duration, h)
    return plain_loop(car, damper, duration, h, master)[1:]


def main() -> None:
    out = Path(sys.argv[1])
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    dyno, _ = write_rig("damper", out / "dyno.csv", RigOptions())
    network = build_fmu(
        train_from_file(dyno, TrainRequest(preset="damper-hysteresis", moving_mass=2.0), out / "damper.onnx").path,
        BuildOptions(out=out / "damper.fmu", platforms=("linux64",)),
    )
    trained = time.perf_counter()
    truth = build_fmu_from_model(damper_truth_graph(TRUTH, T), BuildOptions(out=out / "truth.fmu"))
    car = build_vendor_quarter_car(out / "vendor")
    reference = monolithic(TRUTH, duration, REFERENCE_STEP)
    sampled = reference[:: round(T / REFERENCE_STEP)]
    own = float(nrmse(replay(network, sampled[:, 2], sampled[:, 3], T), sampled[:, 0]))
    rows = []
    for master in ("gauss-seidel", "jacobi", "libcosim"):
        for h in STEPS:
            grid = reference[round(h / REFERENCE_STEP) :: round(h / REFERENCE_STEP), :2]
            row = {"master": master, "step_s": h}
            for name, fmu in (("network", network), ("truth_law", truth)):
                force, body = nrmse(coupled(car, fmu, duration, h, master), grid)
                row[f"{name}_damper_force_nrmse"], row[f"{name}_body_acceleration_nrmse"] = float(force), float(body)
            rows.append(row)
            shares = [100 * row[f"{name}_{channel}_nrmse"] for name in ("network", "truth_law") for channel in CHANNELS]
            print(
                f"{master:12s} h = {h * 1e3:4.1f} ms  network {shares[0]:5.2f} % / {shares[1]:5.2f} %   "
                f"truth law {shares[2]:5.2f} % / {shares[3]:5.2f} %  (damper force / body acceleration)",
                flush=True,
            )
    print(f"open loop (the network's own error): damper force {100 * own:.2f} %")
    result = {
        "duration_s": duration,
        "sample_period_s": T,
        "network_open_loop_damper_force_nrmse": own,
        "training_wall_s": trained - started,
        "wall_s": time.perf_counter() - started,
        "rows": rows,
    }
    print(json.dumps(result))


if __name__ == "__main__":
    main()
