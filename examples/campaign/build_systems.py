"""Build the FMUs and the system the example campaign (`campaign.toml` beside this file) runs on, into `build/`.

Usage: python examples/campaign/build_systems.py
  then: nnfmu batch examples/campaign/campaign.toml --out out/campaign

Everything comes from the shipped presets, no training: the default vehicle parameter file's quarter car, and linear
dampers at the preset's front damping (2400 N.s/m, the reference valving) and at 0.7x and 1.4x of it. A recorded drive
is stood in for by a generated class D road written as CSV, to show a drive-file event.
"""

from pathlib import Path

from nnfmu.data.drive_files import write_drive
from nnfmu.vehicle.drive import DriveSettings, generate_drive
from nnfmu.vehicle.dynamics import VehicleParameters
from nnfmu.workflows.campaign.quarter_car import build_quarter_car_system

HERE = Path(__file__).parent
BUILD = HERE / "build"

damping = VehicleParameters.load().front_damper.damping
paths = build_quarter_car_system(BUILD, {"linear": damping, "soft": 0.7 * damping, "firm": 1.4 * damping})
drive = write_drive(
    generate_drive(DriveSettings(road_class="D", speed=15.0, duration=10.0, seed=7)), BUILD / "rough-road.csv"
)
for name, path in paths.items():
    print(f"{name}: {path}")
print(f"drive file: {drive}")
