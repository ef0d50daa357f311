"""Port derivatives on smooth components: the quarter car's stabilised damper port meeting a component its fitted
element does not match, coupled with the fitted element alone and with the component's derivatives every step.

Usage: python bench/port_derivatives_quarter_car.py [OUT_DIR]
Two stateless components on the quarter car's damper port (the sedan's front-left corner, port built with (100 kN/m,
1500 N.s/m), sampled at the 1 ms step): a linear spring-damper (400 kN/m, 3000 N.s/m) over 1 s and a stiffening one
(200 kN/m + 3e8 N/m^3 x^3, 2000 N.s/m; port built with its linear part) over 3 s, on the class C drive of
bench/cosim_coupling.py, against the monolithic solution with the same law inside (RK4 at 50 us). NRMSE per channel,
last stdout line one JSON object.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx

from nnfmu.component import Component, Port
from nnfmu.cosim.master import CosimSettings, cosimulate
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.export.graph import GraphBuilder
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.dynamics import (
    LinearLaw,
    MonolithicSettings,
    QuarterCarParameters,
    build_quarter_car,
    simulate_monolithic,
)
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu, initial_state

sys.path.insert(0, str(Path(__file__).parent))
from cosim_coupling import quarter_car_drive  # noqa: E402

STEP = 1e-3
CHANNELS = ("damper_force", "damper_displacement", "body_acceleration", "spindle_acceleration")
CASES = {
    "linear 400 kN/m, 3000 N.s/m; port (100 kN/m, 1500 N.s/m)": ((4e5, 0.0, 3000.0), (1e5, 1500.0), 1.0),
    "stiffening 200 kN/m + 3e8 N/m^3, 2000 N.s/m; port (200 kN/m, 2000 N.s/m)": (
        (2e5, 3e8, 2000.0),
        (2e5, 2000.0),
        3.0,
    ),
}


@dataclass(frozen=True)
class CubicLaw:
    """force = k1 x + k3 x^3 + c v, no states (the monolithic reference's law)."""

    k1: float
    k3: float
    c: float
    n_states: int = 0

    def initial_state(self) -> np.ndarray:
        return np.zeros(0)

    def derivatives(self, t: float, state: np.ndarray, x: float, v: float) -> np.ndarray:
        return np.zeros(0)

    def force(self, state: np.ndarray, x: float, v: float) -> float:
        return self.k1 * x + self.k3 * x**3 + self.c * v


def element_graph(k1: float, k3: float, c: float) -> onnx.ModelProto:
    """Stateless `displacement` [m], `velocity` [m/s] -> `force` = k1 x + k3 x^3 + c v [N]."""
    g = GraphBuilder(reserved=("displacement", "velocity", "force"))
    cube = g.node("Mul", [g.node("Mul", ["displacement", "displacement"], "x2"), "displacement"], "x3")
    spring = g.node(
        "Add",
        [
            g.node("Mul", ["displacement", g.constant("k1", np.array([k1]))], "linear"),
            g.node("Mul", [cube, g.constant("k3", np.array([k3]))], "cubic"),
        ],
        "spring",
    )
    viscous = g.node("Mul", ["velocity", g.constant("c", np.array([c]))], "viscous")
    g.output(g.node("Add", [spring, viscous], "sum"), "force")
    model = g.model("element", "k1 x + k3 x^3 + c v", [("displacement", 1), ("velocity", 1)], [("force", 1)])
    Component(
        name="element",
        inputs=[Port("displacement", "m"), Port("velocity", "m/s")],
        outputs=[Port("force", "N")],
        description="spring-damper",
    ).attach_to(model)
    return model


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="nnfmu-bench-port-derivatives-"))
    out.mkdir(parents=True, exist_ok=True)
    params = QuarterCarParameters.load()
    x0 = tuple(initial_state(build_quarter_car(params)))
    found = {}
    for i, (name, ((k1, k3, c), fitted, duration)) in enumerate(CASES.items()):
        folder = out / f"case{i}"
        folder.mkdir(exist_ok=True)
        onnx.save(element_graph(k1, k3, c), folder / "element.onnx")
        element = build_fmu(folder / "element.onnx", BuildOptions(out=folder / "element.fmu"))
        drive = quarter_car_drive(duration)
        law = LinearLaw(k1, c) if k3 == 0.0 else CubicLaw(k1, k3, c)
        exact = simulate_monolithic(
            build_quarter_car(params),
            {"damper_force": law},
            {k: drive[k] for k in drive.names},
            MonolithicSettings(sample_period=drive.sample_period, step=5e-5),
            x0=np.array(x0),
        )
        settings = VehicleBuildSettings(
            components={"damper": "stabilised"},
            sample_period=STEP,
            stabilisers={"damper_force": fitted},
            initial_state=x0,
            port_derivatives=True,
        )
        car = build_vehicle_fmu("quarter-car", folder / "car.fmu", settings)
        ssd = write_ssd(connect_by_name("qc", ("vehicle", car), {"damper": element}, folder), folder / "s.ssd")
        rows = {}
        with open_system(ssd) as system:
            for label, derivatives in (("fitted", False), ("derivatives", True)):
                started = time.perf_counter()
                m = cosimulate(
                    system, drive, CosimSettings(step=STEP, stop_time=duration, port_derivatives=derivatives)
                )
                m = m.measurement
                k = np.round((m.time - drive.time[0]) / drive.sample_period).astype(int)
                rows[label] = {
                    ch: round(float(np.sqrt(np.mean((m[ch] - exact[ch][k]) ** 2)) / np.std(exact[ch][k])), 6)
                    for ch in CHANNELS
                } | {"wall_s": round(time.perf_counter() - started, 2)}
        found[name] = {"duration_s": duration, "nrmse": rows}
        print(json.dumps({name: found[name]}), file=sys.stderr, flush=True)
    print(json.dumps({"step_s": STEP, "cases": found, "load_average": [round(v, 2) for v in os.getloadavg()]}))


if __name__ == "__main__":
    main()
