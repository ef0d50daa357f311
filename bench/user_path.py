"""The user's path at default options on a quarter car nnfmu never saw (issue 28's second done-when).

Every step is the command a user types, run as a subprocess with nothing but the options a first run needs:
`nnfmu rig damper` (the lab dyno record, its 2 kg fixture included), `nnfmu train --preset damper-hysteresis`,
`nnfmu build`, `nnfmu vehicle build quarter-car --params` on a compact car's parameter file written here (none of
the packaged sedan's numbers), an SSD written by hand as a user would, `nnfmu drive generate` (class C, 20 m/s,
a pothole) and `nnfmu cosim` at its default step. The reference is the same car solved monolithically (RK4,
0.1 ms) with the dyno's damper law inside, from the state the vehicle FMU starts in. Options after the duration go
to `nnfmu train` (e.g. `--moving-mass 0`; without them the run is the user's default path). A rerun into the same
folder keeps the files an earlier run wrote (say so, per stage).

Usage: python bench/user_path.py OUT_DIR [DURATION_S] [TRAIN_OPTION ...]  -> JSON on the last line
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from nnfmu.data import load_measurement
from nnfmu.data.derive import derive_rates
from nnfmu.data.rigs import DEFAULT_EFFECTS, DamperTruth
from nnfmu.fmu.build import build_fmu_from_model
from nnfmu.fmu.options import BuildOptions
from nnfmu.validate.metrics import nrmse
from nnfmu.vehicle.dynamics import MonolithicSettings, simulate_monolithic, truth_laws
from nnfmu.vehicle.fmu import VehicleBuildSettings, initial_state, vehicle_model
from nnfmu.workflows.roadtest.truth_graphs import damper_truth_graph

CAR = """\
name = "compact"
description = "front corner of a compact hatchback, written for this benchmark"
gravity = 9.81

[quarter_car]
corner = "fl"
sprung_mass = 310.0
unsprung_mass = 34.0
wheel_rate = 24000.0
tyre_stiffness = 210000.0
tyre_damping = 120.0
damper_motion_ratio = 0.93

[quarter_car.damper]
model = "linear"
damping = 2000.0
"""

SSD = """\
<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="compact">
  <ssd:System name="compact">
    <ssd:Elements>
      <ssd:Component name="car" source="car.fmu" type="application/x-fmu-sharedlibrary">
        <ssd:Connectors>
          <ssd:Connector name="damper_velocity" kind="output"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="damper_force" kind="input"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
      <ssd:Component name="damper" source="damper.fmu" type="application/x-fmu-sharedlibrary">
        <ssd:Connectors>
          <ssd:Connector name="velocity" kind="input"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="force" kind="output"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="car" startConnector="damper_velocity" endElement="damper" endConnector="velocity"/>
      <ssd:Connection startElement="damper" startConnector="force" endElement="car" endConnector="damper_force"/>
    </ssd:Connections>
  </ssd:System>
</ssd:SystemStructureDescription>
"""

CHANNELS = ("damper_force", "body_acceleration", "spindle_acceleration", "damper_displacement")
TARGETS = {"damper_force": 0.02, "body_acceleration": 0.02, "spindle_acceleration": 0.03, "damper_displacement": 0.01}


def nnfmu(*args: str, cwd: Path) -> str:
    """Run one nnfmu command as the user would; its output, or the failure with what it printed."""
    done = subprocess.run(["nnfmu", *args], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"nnfmu {' '.join(args)} failed ({done.returncode}):\n{done.stdout}{done.stderr}")
    return done.stdout + done.stderr


def reference(folder: Path, drive_path: Path) -> dict[str, np.ndarray]:
    """The compact car with the dyno's damper law (the rig's defaults, its fixture's inertia left out: that mass
    is the dyno's, not the car's) inside, RK4 at 0.1 ms, outputs at the drive's samples."""
    vehicle = vehicle_model("quarter-car", VehicleBuildSettings(params_path=folder / "compact.toml"))
    drive = load_measurement(drive_path)
    rates = derive_rates(drive)
    inputs = {p.name: rates[p.name] for p in vehicle.inputs if p.name.startswith("actuator_")}
    return simulate_monolithic(
        vehicle,
        truth_laws(["damper_force"]),
        inputs,
        MonolithicSettings(sample_period=drive.sample_period, step=1e-4, compiled=True),
        x0=np.array(initial_state(vehicle)),
    )


def main() -> None:
    folder = Path(sys.argv[1]).resolve()
    duration = sys.argv[2] if len(sys.argv) > 2 else "20"
    train_options = sys.argv[3:]
    folder.mkdir(parents=True, exist_ok=True)
    stages: dict[str, float] = {}
    started = time.perf_counter()

    def stage(name: str, *args: str) -> str:
        written = folder / args[args.index("--out") + 1]
        if written.exists():  # a rerun into the same folder keeps what an earlier run made
            print(f"{name}: kept {written.name} from an earlier run", flush=True)
            return ""
        begun = time.perf_counter()
        printed = nnfmu(*args, cwd=folder)
        stages[name] = time.perf_counter() - begun
        print(f"{name}: {stages[name]:.1f} s", flush=True)
        return printed

    stage("rig", "rig", "damper", "--out", "dyno.csv")
    trained = stage(
        "train", "train", "dyno.csv", "--preset", "damper-hysteresis", *train_options, "--out", "damper.onnx"
    )
    stage("build", "build", "damper.onnx", "--out", "damper.fmu")
    (folder / "compact.toml").write_text(CAR)
    (folder / "SystemStructure.ssd").write_text(SSD)
    stage("vehicle", "vehicle", "build", "quarter-car", "--params", "compact.toml", "--out", "car.fmu")
    stage(
        "drive",
        "drive",
        "generate",
        "--out",
        "road.csv",
        "--duration",
        duration,
        "--pothole",
        f"{0.4 * float(duration):g}",
    )
    stage("cosim", "cosim", "SystemStructure.ssd", "--drive", "road.csv", "--out", "result.csv")
    # the coupling's share: the dyno's own law (no fixture) as an FMU in the network's place, same SSD otherwise
    law = DamperTruth(effects=tuple(e for e in DEFAULT_EFFECTS["damper"] if e != "inertia"))
    (folder / "law").mkdir(exist_ok=True)
    build_fmu_from_model(damper_truth_graph(law, 1e-3), BuildOptions(out=folder / "law" / "damper.fmu"))
    (folder / "law" / "car.fmu").write_bytes((folder / "car.fmu").read_bytes())
    (folder / "law" / "SystemStructure.ssd").write_text(SSD)
    stage("cosim_law", "cosim", "law/SystemStructure.ssd", "--drive", "road.csv", "--out", "law/result.csv")
    truth = reference(folder, folder / "road.csv")
    pothole = 0.4 * float(duration)
    errors: dict[str, dict[str, float]] = {"network": {}, "truth_law": {}, "network_without_pothole": {}}
    for run, result_path in (("network", "result.csv"), ("truth_law", "law/result.csv")):
        result = load_measurement(folder / result_path)
        calm = (result.time < pothole - 0.5) | (result.time > pothole + 1.5)  # both axles' hits and the ringing
        for channel in CHANNELS:
            name = next(n for n in result.channels if n.endswith(channel))
            want = np.interp(result.time, truth["time"], truth[channel])
            errors[run][channel] = nrmse(result[name], want)
            if run == "network":
                errors["network_without_pothole"][channel] = nrmse(result[name][calm], want[calm])
    for channel in CHANNELS:
        total, coupling = errors["network"][channel], errors["truth_law"][channel]
        verdict = "meets" if total <= TARGETS[channel] else "misses"
        print(
            f"{channel}: NRMSE {100 * total:.2f} % ({verdict} {100 * TARGETS[channel]:.0f} %); "
            f"the dyno's law in the network's place {100 * coupling:.2f} %; the network without the pothole's 2 s "
            f"{100 * errors['network_without_pothole'][channel]:.2f} %"
        )
    notes = [line for line in trained.splitlines() if line.startswith(("note:", "warning:"))]
    print(
        json.dumps(
            {
                "train_options": train_options,
                "nrmse": errors,
                "targets": TARGETS,
                "notes": notes,
                "stage_wall_s": stages,
                "wall_s": time.perf_counter() - started,
            }
        )
    )


if __name__ == "__main__":
    main()
