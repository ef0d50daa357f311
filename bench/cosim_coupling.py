"""Co-simulation error against the monolithic reference: quarter car FMU + linear damper FMU, steps x schemes (JSON)."""
import json, sys, time, tempfile
from pathlib import Path
import numpy as np
import onnx
from nnfmu.cosim.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.data.derive import derive_rates
from nnfmu.data import Measurement
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.fmu.build import build_vehicle_fmu
from nnfmu.vehicle.fmu.settings import VehicleBuildSettings
from nnfmu.vehicle.models import MonolithicSettings, LinearLaw, QuarterCarParameters, build_quarter_car, simulate_monolithic

DURATION = float(sys.argv[1]) if len(sys.argv) > 1 else 5.0
folder = Path(tempfile.mkdtemp(prefix="h14-bench-"))
d4 = generate_drive(DriveSettings(duration=DURATION))
x = d4["actuator_fl_displacement"]
drive = derive_rates(Measurement(d4.time, {"actuator_fl_displacement": x}, {"actuator_fl_displacement": "m"},
                                 "class C drive, fl"))  # the quarter car stands on the fl post
drive = Measurement(drive.time, {k: drive[k] for k in ("actuator_fl_displacement", "actuator_fl_velocity")},
                    {"actuator_fl_displacement": "m", "actuator_fl_velocity": "m/s"}, drive.source)
vehicle_fmu = build_vehicle_fmu("quarter-car", folder / "quarter_car.fmu", VehicleBuildSettings())
onnx.save(linear_damper_graph(QuarterCarParameters.load().damper.damping), folder / "damper.onnx")
damper_fmu = build_fmu(folder / "damper.onnx", BuildOptions(out=folder / "damper.fmu"))  # the front damper's linear reference
ssd = write_ssd(connect_by_name("quarter car + damper", ("vehicle", vehicle_fmu), {"damper": damper_fmu}, folder,
                                parameters={"damper": {"filter_cutoff": 0.0}}), folder / "SystemStructure.ssd")
vehicle = build_quarter_car(QuarterCarParameters.load())
damping = QuarterCarParameters.load().damper.damping
t0 = time.perf_counter()
mono = simulate_monolithic(vehicle, {"damper_force": LinearLaw(0.0, damping)},
                           {k: drive[k] for k in drive.names}, MonolithicSettings(sample_period=drive.sample_period, step=5e-5))
mono_s = time.perf_counter() - t0
schemes = {
    "gauss-seidel": {}, "jacobi": {"scheme": "jacobi"},
    "gauss-seidel+linear": {"extrapolation": "linear"}, "jacobi+linear": {"scheme": "jacobi", "extrapolation": "linear"},
    "gauss-seidel+iterative": {"iterations": 30, "tolerance": 1e-10},
}
signals = ("damper_velocity", "body_acceleration", "body_displacement", "damper_force")
rows = []
with open_system(ssd) as system:
    for h in (0.5e-3, 1e-3, 2e-3, 5e-3):
        stride = round(h / drive.sample_period) if h >= drive.sample_period else None
        for name, kw in schemes.items():
            t1 = time.perf_counter()
            r = cosimulate(system, drive, CosimSettings(step=h, **kw))
            wall = time.perf_counter() - t1
            m = r.measurement
            errs = {}
            for s in signals:
                ref = mono[s] if s in mono else None
                if ref is None:
                    continue
                # compare on the instants both have (the reference is sampled at the drive's period)
                common = max(h, drive.sample_period)
                n_common = int(round(m.time[-1] / common)) + 1
                mine = np.round(np.arange(n_common) * common / h).astype(int)
                theirs = np.round(np.arange(n_common) * common / drive.sample_period).astype(int)
                errs[s] = float(np.max(np.abs(m[s][mine] - ref[theirs])) / np.max(np.abs(ref)))
            rows.append({"step_ms": h * 1e3, "scheme": name, "rel_peak_error": errs,
                         "mean_iterations": round(r.mean_iterations, 2), "unconverged": r.unconverged_steps,
                         "wall_s": round(wall, 2)})
            print(json.dumps(rows[-1]), flush=True)
print(json.dumps({"duration_s": DURATION, "monolithic_rk4_step_s": 5e-5, "monolithic_wall_s": round(mono_s, 1)}))
