"""A system of the vendor quarter car (`vendor_fmu.py`) and a damper FMU built by nnfmu, and a road drive for it."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1] / "cosim"))
from cosim_system_helpers import NO_FILTER, build, damper_graph  # noqa: E402
from vendor_fmu import build_vendor_quarter_car  # noqa: E402

from nnfmu.cosim.ssp import Connection, Connector, Element, SystemStructure, write_ssd  # noqa: E402
from nnfmu.data import Measurement, save_measurement  # noqa: E402

VEHICLE = "vehicle"
DAMPER = "damper"
VEHICLE_PORTS = (
    ("zr", "input"),
    ("F_damper", "input"),
    ("x_damper", "output"),
    ("v_damper", "output"),
    ("a_body", "output"),
    ("a_spindle", "output"),
    ("z_body", "output"),
    ("F_tyre", "output"),
)


def write_vendor_system(
    folder: Path,
    connections: tuple[Connection, ...] | None = None,
    damper_fmu: Path | None = None,
    velocity_unit: str = "m/s",
) -> Path:
    """SystemStructure.ssd in `folder`: the vendor quarter car (v_damper in `velocity_unit`), its v_damper into an
    nnfmu linear damper (F = c v, stateless, or `damper_fmu`) whose force drives F_damper; `connections` replaces
    that wiring (a miswired system)."""
    vehicle = build_vendor_quarter_car(folder / "vehicle", velocity_unit)
    damper = damper_fmu if damper_fmu is not None else build(damper_graph(), folder / "damper", "damper")
    wiring = connections or (
        Connection(VEHICLE, "v_damper", DAMPER, "velocity"),
        Connection(DAMPER, "force", VEHICLE, "F_damper"),
    )
    system = SystemStructure(
        name="vendor quarter car with damper",
        elements=[
            Element(VEHICLE, str(vehicle.relative_to(folder)), tuple(Connector(n, k) for n, k in VEHICLE_PORTS)),
            Element(
                DAMPER,
                os.path.relpath(damper, folder),
                (Connector("velocity", "input"), Connector("force", "output")),
                dict(NO_FILTER),
            ),
        ],
        connections=list(wiring),
        base=folder,
    )
    return write_ssd(system, folder / "SystemStructure.ssd")


def road(duration: float, period: float = 1e-4) -> Measurement:
    """Road displacement `zr` [m]: a smooth bump train of 2 and 9 Hz, 0 at t = 0."""
    t = np.arange(round(duration / period) + 1) * period
    zr = 0.01 * (1 - np.cos(2 * np.pi * 2.0 * t)) + 0.003 * (1 - np.cos(2 * np.pi * 9.0 * t))
    return Measurement(t, {"zr": zr}, {"zr": "m"}, source="vendor road")


def write_road(path: Path, duration: float) -> Path:
    return save_measurement(road(duration), path)
